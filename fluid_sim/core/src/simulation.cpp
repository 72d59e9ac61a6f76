// The simulation: what a scene holds (fluid, bodies, neighbourhoods, the pressure solver) and
// the time step as the paper's Algorithm 1 (Simulation::Impl::step). Equation numbers refer to
// docs/method.md; each phase's code is in the file its comment names.

#include "fluid_sim/core/simulation.h"

#include <algorithm>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>

#include "fluid_sim/core/bodies.h"
#include "fluid_sim/core/bullet_contacts.h"
#include "fluid_sim/core/dfsph_solver.h"
#include "fluid_sim/core/emitters.h"
#include "fluid_sim/core/fill_relaxation.h"
#include "fluid_sim/core/fluid_constants.h"
#include "fluid_sim/core/fluid_fill.h"
#include "fluid_sim/core/fluid_particles.h"
#include "fluid_sim/core/measurements.h"
#include "fluid_sim/core/neighborhoods.h"
#include "fluid_sim/core/non_pressure_forces.h"
#include "fluid_sim/core/parallel.h"
#include "fluid_sim/core/rigid_dynamics.h"
#include "fluid_sim/core/step_checks.h"
#include "fluid_sim/core/step_timer.h"
#include "fluid_sim/core/wall_guard.h"

namespace fluid_sim
{
struct Simulation::Impl
{
  static const SceneConfig& validated(const SceneConfig& cfg)
  {
    validate(cfg);  // before any member (grids, kernel) is built from the values
    return cfg;
  }

  explicit Impl(const SceneConfig& cfg)
      : scene(validated(cfg))
      , constants(scene)
      , bodies(scene)
      , fill(fillFluid(scene, bodies, fluid))
      , initial_count(fluid.size())
      , neighbors(scene, constants.kernel)
      , forces(scene.viscosity, constants)
      , solver(makePressureSolver({scene, constants, fluid, bodies, neighbors}, fluid))
      , dt_next(computeTimeStep(scene.time_step, fluid, constants.gravity, scene.spacing,
                                bodies.maxSpeedAhead(0.0, scene.time_step.max)))
      , emitters(scene, bodies)
  {
    for (const RegionConfig& sink : scene.sinks) sink_totals.push_back({sink.name, 0, 0.0, 0.0});
    // Without free bodies no contact model (no Bullet world) is built.
    if (bodies.hasFree())
    {
      if (scene.contacts.model == ContactModel::Bullet)
        contacts = std::make_unique<BulletContacts>(bodies, scene.spacing, scene.contacts);
      else
        contacts = std::make_unique<ContactSolver>(scene.spacing, scene.contacts);
    }
    // The emitters' water is stored from the start where its amount is known: no reallocation
    // while they run (fields and their sort scratch). Up to a million particles (56 MB of fields
    // and sort scratch) are reserved; beyond that the storage grows geometrically (a
    // reallocation per doubling, not per emission).
    if (!emitters.empty()) fluid.reserve(fluid.size() + std::min<std::size_t>(emitters.expectedParticles(), 1000000));
    fill_report.trimmed = fill.trimmed;
    fill_report.overlapped = fill.overlapped;
    start_warnings = bodies.startWarnings();
    start_warnings.insert(start_warnings.end(), fill.warnings.begin(), fill.warnings.end());
    {
      // Eqs. A22, A23 (fill_relaxation.cpp), with a solver of its own: this one is not touched,
      // and the velocities, and so dt_next, are the fill's again afterwards. Its pseudo-step
      // (used without gravity) is the fluid's: the bodies are held still while it runs. With
      // fill.relax off the lattice is only measured (its summary read 0 % for a lattice 26 % over
      // rest density in a rotated tank): the first step sorts the particles from the same order
      // either way.
      PhaseTimer timer(fill_report.ms_relax);
      relaxFill(scene, constants, fill.kind,
                computeTimeStep(scene.time_step, fluid, constants.gravity, scene.spacing, 0.0), fluid, bodies,
                neighbors, fill_report, !scene.fill.relax);
    }
  }

  StepReport step(double max_dt)
  {
    StepReport rep;
    {
      PhaseTimer total(rep.ms_total);
      advance(rep, max_dt);
    }
    return rep;
  }

  /// One time step, as Algorithm 1 of the paper (DFSPH, Bender & Koschier 2017).
  void advance(StepReport& rep, double max_dt)
  {
    const double dt = std::min(dt_next, max_dt);  // s

    // 0. Bodies to their poses at t, with velocities and accelerations (Eq. A17; bodies.cpp).
    bodies.poseMoving(t);

    // 1. Neighbourhoods at x(t) (neighborhoods.cpp; the extrapolations' fit lists in
    //    boundary_pressure_methods.cpp).
    {
      PhaseTimer timer(rep.ms_neighbors);
      neighbors.sortFluid(fluid);
      neighbors.build(fluid, bodies);
      solver->buildBoundaryLists();
    }
    rep.neighbor_pairs = neighbors.fluid_fluid.pairs() + neighbors.fluid_boundary.pairs();

    // 2. Densities (Eq. A1), diagonal (Eq. A4), density rates (Eq. A2); the extrapolation
    //    coefficients (Eq. 3, Eqs. 7-16) for both solves (dfsph_solver.cpp).
    solver->computeDensityAndDiagonal();
    rep.max_density_error =
        parallelMax(fluid.size(), [&](std::size_t i) { return (fluid.rho[i] - constants.rho0) / constants.rho0; });

    BodyWrenches wrenches(bodies.size());
    // 3. Divergence solve (Eqs. A5, A7-A10, with Eq. 1): v* = v + dt a^p.
    {
      PhaseTimer timer(rep.ms_divergence);
      if (scene.solver.divergence_solve) solver->divergenceSolve(dt, rep, wrenches);
    }

    // 4. Non-pressure accelerations (gravity, Eq. A13 or A14): v** = v* + dt a^np
    //    (non_pressure_forces.cpp).
    forces.apply(dt, fluid, neighbors, bodies, wrenches, solver->forceScratch());

    // 5. Density solve (Eqs. A6-A10, with Eq. 1) with v**.
    {
      PhaseTimer timer(rep.ms_density);
      solver->densitySolve(dt, rep, wrenches);
      // 6. v(t + dt) = v** + dt a^p, x(t + dt) = x(t) + dt v(t + dt) (Eq. A16), then the wall
      //    guard (Eq. A31; wall_guard.cpp): no particle's step ends across a wall's layer. Its
      //    momentum goes to the walls' wrenches.
      guard.prepare(scene.solver.wall_guard * scene.spacing, scene.spacing, constants.kernel, fluid, bodies,
                    neighbors.fluid_boundary);
      solver->integrate(dt);
      const WallGuardReport guarded =
          guard.apply(dt, constants.kernel, fluid, bodies, constants.mass, wrenches, neighbors.fluid_boundary);
      rep.wall_guarded = guarded.particles;
      rep.wall_guard_max_shift = guarded.max_shift;
    }
    rep.boundary_pressure_work = solver->boundaryPressureWork();
    // The fluid's force and torque on each body over the step (Eq. A12), and its contacts.
    bodies.updateReports(wrenches, neighbors.fluid_boundary, fluid.size(),
                         [&](std::size_t i, Index b) { return solver->wallPressure(i, b); });
    // Free bodies move under gravity, the fluid's wrench of this step and contacts, to their
    // poses at t + dt (Eqs. A24-A26; rigid_dynamics.cpp). Nothing for a scene without them.
    const std::string body_fault = contacts ? bodies.stepFree(dt, scene.gravity, *contacts) : std::string();
    t += dt;
    rep.time = t;
    rep.dt = dt;

    // 7. Blow-ups are reported and the state kept as it is for inspection; otherwise particles
    //    that left the domain are removed (step_checks.cpp). A free body that came out of its step
    //    non-finite is one too (it would spread to the water in the next step).
    const std::size_t culprit = checkStability(fluid, scene, constants.mass, dt, rep);
    if (culprit != kNoParticle)
      rep.reason += "; " + describeParticle(culprit, dt, scene.domain, fluid, neighbors, bodies);
    if (!body_fault.empty() && !rep.unstable)
    {
      rep.unstable = true;
      rep.reason = body_fault;
    }
    // A free body whose centre of mass left the domain falls on with nothing to hold it (the
    // domain removes water, not bodies): said once, so that a user sees why it is gone.
    if (bodies.hasFree())
    {
      left_domain.resize(bodies.size(), false);
      for (std::size_t k = 0; k < bodies.size(); ++k)
      {
        if (!bodies[k].free || left_domain[k]) continue;
        const Vec3d c = bodies[k].centerOfMass();
        if (scene.domain.contains(c)) continue;
        left_domain[k] = true;
        rep.notices.push_back("free body '" + bodies[k].config.name + "' left the domain at t = " + numberText(t) +
                              " s (its centre of mass at (" + numberText(c.x()) + ", " + numberText(c.y()) + ", " +
                              numberText(c.z()) + ") m); nothing holds it there");
      }
    }
    if (!rep.unstable)
    {
      rep.removed = removeOutsideDomain(fluid, scene.domain);
      removed_total += rep.removed;
      if (!scene.sinks.empty()) rep.drained = drain();
      // Emitters release the layers whose time came in this step, at the nozzles' poses now
      // (emitters.cpp); they join the next step's neighbourhoods.
      if (!emitters.empty()) rep.emitted = emitters.emit(t - dt, dt, fluid, bodies);
    }
    rep.fluid_particles = fluid.size();
    solver->report(rep);

    // 8. The next time step (Eq. A15), for the fluid's speeds and the moving bodies' up to t + dt_max.
    dt_next = computeTimeStep(scene.time_step, fluid, constants.gravity, scene.spacing,
                              bodies.maxSpeedAhead(t, scene.time_step.max));
  }

  /// Removes the fluid particles inside a sink, each counted against the first sink (in the
  /// scene's order) that holds it; returns how many.
  std::size_t drain()
  {
    const std::size_t n = fluid.size();
    std::vector<std::int32_t> in(n, -1);  // the sink holding each particle, or -1
    std::vector<RegionTest> tests;
    for (const RegionConfig& r : scene.sinks) tests.emplace_back(r, r.pose, nullptr);
    parallelFor(n, [&](std::size_t i) {
      const Vec3d x = fluid.x[i].cast<double>();
      for (std::size_t k = 0; k < tests.size(); ++k)
        if (tests[k].contains(x))
        {
          in[i] = std::int32_t(k);
          return;
        }
    });
    std::vector<std::uint8_t> keep(n, 1);
    std::size_t drained = 0;
    for (std::size_t i = 0; i < n; ++i)  // serial: the counts, in particle order
      if (in[i] >= 0)
      {
        keep[i] = 0;
        SinkTotal& total = sink_totals[std::size_t(in[i])];
        ++total.particles;
        // Each particle stands for the cube of one spacing at rest density (as the fill makes it).
        total.volume += scene.spacing * scene.spacing * scene.spacing;
        total.mass += scene.rest_density * scene.spacing * scene.spacing * scene.spacing;
        ++drained;
      }
    if (drained > 0) fluid.keepIf(keep);
    return drained;
  }

  SceneConfig scene;
  FluidConstants constants;
  BodySet bodies;
  FluidParticles fluid;
  FillResult fill;                          // the initial fill: points left out, which particles are lattice points
  FillReport fill_report;                   // trimming and relaxation before t = 0
  std::vector<std::string> start_warnings;  // the bodies' and the fill's (startWarnings())
  std::size_t initial_count;                // fluid particles at t = 0
  Neighborhoods neighbors;
  NonPressureForces forces;
  std::unique_ptr<PressureSolver> solver;  // compiled for the scene's boundary pressure method
  WallGuard guard;                         // Eq. A31, per step
  double t = 0.0;                          // s, simulated time
  double dt_next;                          // s, the time step of the next step()
  std::size_t removed_total = 0;           // particles that left the domain since t = 0
  // Free bodies' contacts (contacts.model), built only for a scene with free bodies.
  std::unique_ptr<ContactResolver> contacts;
  std::vector<SinkTotal> sink_totals;  // per scene sink, since t = 0
  Emitters emitters;                   // the scene's nozzles (none: nothing per step)
  std::vector<bool> left_domain;       // per body: a free body whose leaving was reported
};

Simulation::Simulation(const SceneConfig& scene) : impl_(std::make_unique<Impl>(scene)) {}
Simulation::~Simulation() = default;

StepReport Simulation::step(double max_dt)
{
  if (!(max_dt > 0.0))
    throw std::invalid_argument("Simulation::step: max_dt must be > 0 (got " + std::to_string(max_dt) + ")");
  return impl_->step(max_dt);
}

void Simulation::setBodyPose(std::size_t index, const Pose& pose, bool jump)
{
  if (index >= impl_->bodies.size()) throw ConfigError("body", "no body with index " + std::to_string(index));
  const Body& body = impl_->bodies[index];
  if (!body.config.externally_posed)
    throw ConfigError(body.config.name, "body is not externally posed (set `external: true`)");
  // A NaN or infinite pose would move every particle of the body to nowhere (the body vanishes
  // and the fluid it held is kept): refused, and the body keeps its last pose.
  if (!pose.translation.allFinite() || !pose.rotation.coeffs().allFinite())
  {
    std::ostringstream os;
    os << "setBodyPose: body '" << body.config.name << "': the pose is not finite (translation ["
       << pose.translation.x() << ", " << pose.translation.y() << ", " << pose.translation.z() << "] m, rotation (w "
       << pose.rotation.w() << ", x " << pose.rotation.x() << ", y " << pose.rotation.y() << ", z " << pose.rotation.z()
       << "))";
    throw std::invalid_argument(os.str());
  }
  impl_->bodies.setPendingPose(index, pose, jump);
}

void Simulation::updateSettings(const SolverConfig& solver, const ViscosityConfig& viscosity,
                                const StabilityConfig& stability)
{
  const SolverConfig& old = impl_->scene.solver;
  if (solver.boundary_pressure != old.boundary_pressure)
    throw ConfigError("solver.boundary_pressure",
                      "is fixed when the simulation is built (" + std::string(toString(old.boundary_pressure)) + ")");
  if (solver.mls_fit_radius != old.mls_fit_radius || solver.mls_eigen_tolerance != old.mls_eigen_tolerance ||
      solver.mls_singular != old.mls_singular)
    throw ConfigError("solver.mls_fit_radius", "the MLS fit settings are fixed when the simulation is built");
  SceneConfig next = impl_->scene;
  next.solver = solver;
  next.viscosity = viscosity;
  next.stability = stability;
  validate(next);  // throws before anything changes
  impl_->scene.solver = solver;
  impl_->scene.viscosity = viscosity;
  impl_->scene.stability = stability;
}

std::size_t Simulation::bodyIndex(const std::string& name) const
{
  for (std::size_t k = 0; k < impl_->bodies.size(); ++k)
    if (impl_->bodies[k].config.name == name) return k;
  throw ConfigError(name, "no boundary body with this name");
}

double Simulation::time() const
{
  return impl_->t;
}
double Simulation::nextTimeStep() const
{
  return impl_->dt_next;
}
const SceneConfig& Simulation::scene() const
{
  return impl_->scene;
}
std::size_t Simulation::numFluidParticles() const
{
  return impl_->fluid.size();
}
const std::vector<Vec3>& Simulation::positions() const
{
  return impl_->fluid.x;
}
const std::vector<Vec3>& Simulation::velocities() const
{
  return impl_->fluid.v;
}
const std::vector<Real>& Simulation::pressures() const
{
  return impl_->fluid.p_total;
}
const std::vector<Real>& Simulation::densitySolvePressures() const
{
  return impl_->fluid.p_density;
}
const std::vector<Real>& Simulation::divergenceSolvePressures() const
{
  return impl_->fluid.p_divergence;
}
const std::vector<Real>& Simulation::densities() const
{
  return impl_->fluid.rho;
}
std::size_t Simulation::numBodies() const
{
  return impl_->bodies.size();
}

BodyInfo Simulation::body(std::size_t index) const
{
  if (index >= impl_->bodies.size())
    throw std::out_of_range("Simulation::body: no body with index " + std::to_string(index));
  const Body& b = impl_->bodies[index];
  BodyInfo info;
  info.name = b.config.name;
  info.inside = b.config.inside;
  info.moving = b.moving;
  info.first_particle = b.offset;
  info.num_particles = b.local.size();
  info.pose = b.pose;
  info.linear_velocity = b.v_origin;
  info.angular_velocity = b.omega;
  info.force = b.force;
  info.torque = b.torque;
  info.force_body = b.pose.rotation.conjugate() * b.force;
  info.torque_body = b.pose.rotation.conjugate() * b.torque;
  info.contact_particles = b.contact;
  info.max_pressure = b.max_pressure;
  info.free = b.free;
  info.center_of_mass = b.free ? b.centerOfMass() : b.pose.translation;
  info.com_velocity = b.free ? b.v_com : b.v_origin;
  info.torque_com = b.torque - (info.center_of_mass - b.pose.translation).cross(b.force);
  info.contact_force = b.contact_force;
  if (b.free)
  {
    info.mass = b.mass;
    info.inertia = b.inertia_local;
  }
  return info;
}

const std::vector<Vec3>& Simulation::boundaryPositions() const
{
  return impl_->bodies.x;
}
const std::vector<Vec3>& Simulation::boundaryVelocities() const
{
  return impl_->bodies.v;
}
const std::vector<Real>& Simulation::boundaryPressures() const
{
  return impl_->solver->boundaryPressures();
}
const std::vector<Real>& Simulation::boundaryVolumes() const
{
  return impl_->bodies.volume;
}
std::size_t Simulation::initialFluidParticles() const
{
  return impl_->initial_count;
}
std::size_t Simulation::removedAtStart() const
{
  return impl_->fill.dropped;
}
const std::vector<std::string>& Simulation::startWarnings() const
{
  return impl_->start_warnings;
}

const FillReport& Simulation::fillReport() const
{
  return impl_->fill_report;
}
std::size_t Simulation::removedTotal() const
{
  return impl_->removed_total;
}
const std::vector<SinkTotal>& Simulation::sinkTotals() const
{
  return impl_->sink_totals;
}
const std::vector<EmitterTotal>& Simulation::emitterTotals() const
{
  return impl_->emitters.totals();
}
void Simulation::setEmitterPose(std::size_t index, const Pose& pose)
{
  if (index >= impl_->scene.emitters.size())
    throw ConfigError("emitters", "no emitter with index " + std::to_string(index));
  const EmitterConfig& e = impl_->scene.emitters[index];
  if (!e.externally_posed) throw ConfigError(e.name, "emitter is not posed from outside");
  if (!pose.translation.allFinite() || !pose.rotation.coeffs().allFinite())
    throw std::invalid_argument("setEmitterPose: emitter '" + e.name + "': the pose is not finite");
  impl_->emitters.setPose(index, pose);
}
Pose Simulation::emitterPose(std::size_t index) const
{
  return impl_->emitters.worldPose(index, impl_->bodies);
}
double Simulation::particleMass() const
{
  return impl_->constants.mass;
}

}  // namespace fluid_sim
