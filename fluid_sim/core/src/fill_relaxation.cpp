// The relaxation of the initial lattice (see fill_relaxation.h; Eqs. A22, A23 of docs/method.md).

#include "fluid_sim/core/fill_relaxation.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "fluid_sim/core/dfsph_solver.h"
#include "fluid_sim/core/parallel.h"
#include "fluid_sim/core/wall_guard.h"

namespace fluid_sim
{
namespace
{
/// data[k] becomes data[order[k]] (as FluidParticles::reorder does).
template <class T>
void permute(std::vector<T>& data, const std::vector<Index>& order)
{
  std::vector<T> out(data.size());
  for (std::size_t k = 0; k < data.size(); ++k) out[k] = data[order[k]];
  data.swap(out);
}
}  // namespace

double latticeDensityError(const std::vector<Real>& rho, const std::vector<FillKind>& kind, Real rho0, bool under_too)
{
  return parallelMax(rho.size(), [&](std::size_t i) {
    const double e = double((rho[i] - rho0) / rho0);
    switch (kind[i])
    {
      case FillKind::LatticeInterior:
        return under_too ? std::abs(e) : std::max(e, 0.0);
      case FillKind::LatticeFace:
        return std::max(e, 0.0);
      case FillKind::Explicit:
        break;
    }
    return 0.0;
  });
}

void relaxFill(const SceneConfig& scene, const FluidConstants& constants, const std::vector<FillKind>& fill_kind,
               double dt, FluidParticles& fluid, BodySet& bodies, Neighborhoods& neighbors, FillReport& report,
               bool measure_only)
{
  const std::size_t n = fluid.size();
  const Real rho0 = constants.rho0;  // kg/m^3
  if (std::none_of(fill_kind.begin(), fill_kind.end(), [](FillKind k) { return k != FillKind::Explicit; })) return;

  // What must come back exactly: the fill's order, every particle's velocity, the explicit
  // particles' positions, and the bodies' velocities and accelerations.
  const std::vector<Vec3> x0 = fluid.x, v0 = fluid.v;
  const std::vector<Vec3> body_v = bodies.v, body_a = bodies.a;
  std::vector<Index> original(n);  // original[k]: the fill's index of the particle now at k
  for (std::size_t i = 0; i < n; ++i) original[i] = Index(i);
  std::vector<FillKind> kind = fill_kind;       // in the current order
  std::vector<Vec3> before;                     // m, positions before a pseudo-step
  std::vector<Vec3> velocity(n, Vec3::Zero());  // m/s, pseudo-velocities at the end of the last pseudo-step

  // The walls stand still: a turning container's velocity would enter the density rate (Eq. A2)
  // and drag the water along before t = 0.
  std::fill(bodies.v.begin(), bodies.v.end(), Vec3::Zero());
  std::fill(bodies.a.begin(), bodies.a.end(), Vec3::Zero());
  std::fill(fluid.v.begin(), fluid.v.end(), Vec3::Zero());  // the pseudo-velocity starts at rest
  const double lattice_count =
      double(std::count_if(fill_kind.begin(), fill_kind.end(), [](FillKind k) { return k != FillKind::Explicit; }));

  // A solver of its own for the scene's boundary method: the settled state is the one the step's
  // solver holds still (relaxed with mirroring's wall term and run with MLS, the 0.25 m sphere
  // moved at 0.14-0.16 m/s 0.1 s after t = 0, relaxed with MLS at 0.03-0.06; velocities zeroed
  // each pseudo-step in both, docs/method_notes.md). Cold starts, and each pseudo-step's
  // solve converged (at least 100 sweeps allowed): a scene's fixed iteration count (the rotating
  // sphere's 10) would leave a pseudo-step's compression behind. The step's own solver is not
  // touched.
  SceneConfig relax_scene = scene;
  relax_scene.solver.warm_start = false;
  relax_scene.solver.max_iterations = std::max(scene.solver.max_iterations, 100);
  relax_scene.solver.min_iterations = std::min(scene.solver.min_iterations, 2);
  const std::unique_ptr<PressureSolver> solver =
      makePressureSolver({relax_scene, constants, fluid, bodies, neighbors}, fluid);
  WallGuard guard;

  // Eq. A22: the pseudo-step tau (s). Under gravity, gravity alone moves a particle kRelaxFall
  // spacings per pseudo-step (with the solver's own dt, 10^-5 m at 1 ms: a gap of half a spacing
  // would take a thousand pseudo-steps to close); without gravity only compression moves the
  // water, and tau cancels out of the displacement dt^2 a^p.
  const double g = scene.gravity.norm();  // m/s^2
  const bool gravity = g > 0.0;
  const double tau = gravity ? std::sqrt(kRelaxFall * scene.spacing / g) : dt;            // s
  const Vec3 v_fall = gravity ? Vec3((tau * scene.gravity).cast<Real>()) : Vec3::Zero();  // m/s
  // Settled: every lattice particle within the tolerance of rest density (Eq. A23) and, under
  // gravity, the mean pseudo-step displacement below a tenth of a free fall's (the water is held).
  const double tolerance = scene.fill.relax_tolerance;
  const double settled_step = 0.1 * kRelaxFall * scene.spacing;  // m
  double mean_step = 0.0;                                        // m, of the last pseudo-step
  const Real max_shift = Real(2.0 * scene.spacing);              // m, from the lattice point

  for (int step = 0;; ++step)
  {
    neighbors.sortFluid(fluid);
    const std::vector<Index>& order = neighbors.fluidGrid().order();
    permute(original, order);
    permute(kind, order);
    neighbors.build(fluid, bodies);
    solver->buildBoundaryLists();
    // The density rate (Eq. A2) of the pseudo-step's start, from rest; the pseudo-velocity is kept
    // aside.
    velocity.swap(fluid.v);
    std::fill(fluid.v.begin(), fluid.v.end(), Vec3::Zero());
    solver->computeDensityAndDiagonal();  // Eq. A1 at the current positions
    const double error = latticeDensityError(fluid.rho, kind, rho0, gravity);
    if (step == 0) report.initial_density_error = error;
    report.final_density_error = error;
    report.relax_steps = step;
    const bool held = step == 0 || !gravity || mean_step <= settled_step;
    if (error <= tolerance && held) break;
    if (measure_only || step == scene.fill.relax_max_steps)
    {
      report.settled = false;  // reported by the runner and the node, not hidden
      break;
    }
    report.relaxed = true;

    // Eq. A22: one pseudo-step of damped settling. Each lattice particle starts it with
    // kRelaxKeep of its last pseudo-velocity plus tau g (Eq. A16's v** without a divergence
    // solve); the density solve (Eq. A6) finds the pressures that keep the water at rest density
    // over tau, pushing over-dense particles apart; integrating moves each particle by tau v**
    // + tau^2 a^p, so that the water sinks into the gaps the trim left at the walls until it is
    // held. None of this velocity reaches t = 0.
    parallelFor(n, [&](std::size_t i) {
      fluid.v[i] = kind[i] == FillKind::Explicit ? Vec3::Zero() : Vec3(v_fall + Real(kRelaxKeep) * velocity[i]);
    });
    StepReport rep;
    BodyWrenches wrenches(bodies.size());
    solver->densitySolve(tau, rep, wrenches);
    before = fluid.x;
    // The wall guard (Eq. A31) as in a step: no pseudo-step carries a particle into a wall's
    // layer, through a thin shell (an open mesh) included, which the test below cannot see.
    guard.prepare(scene.solver.wall_guard * scene.spacing, scene.spacing, constants.kernel, fluid, bodies,
                  neighbors.fluid_boundary);
    solver->integrate(tau);
    guard.apply(tau, constants.kernel, fluid, bodies, constants.mass, wrenches, neighbors.fluid_boundary);
    parallelFor(n, [&](std::size_t i) {
      const Vec3& start = x0[original[i]];
      if (kind[i] == FillKind::Explicit)
      {
        fluid.x[i] = start;  // a saved state's particle stays put
        return;
      }
      // No lattice particle moves farther than two spacings from its lattice point: water that
      // nothing holds (a block in the air next to a cut one) would otherwise fall through the
      // whole relaxation. The gaps the trim leaves are under a spacing (Eq. A21), but the damped
      // settling overshoots: a bound of 1 s took hold in the 0.2 m sphere and the tilted box and left
      // them moving at 0.025 and 0.036 m/s 0.1 s after t = 0 (0.016 and 0.017 unbounded), 1.5 s
      // still in the tilted box; 2 s in neither.
      const Vec3 d = fluid.x[i] - start;
      if (d.squaredNorm() > max_shift * max_shift)
      {
        fluid.x[i] = start + d * (max_shift / d.norm());
        fluid.v[i] = Vec3::Zero();
      }
      // Nor through a wall: a pseudo-step that would carry a particle into a solid or out of
      // every container is not taken for it (with single-term mirroring, whose wall term is
      // weakest, 38 of 6,467 particles of the rotating sphere started up to 1.5 spacings outside
      // it, and one fell out of the domain).
      if (outsideTheWater(fluid.x[i].cast<double>(), bodies))
      {
        fluid.x[i] = before[i];
        fluid.v[i] = Vec3::Zero();
      }
    });
    mean_step = parallelSum(n, [&](std::size_t i) { return double((fluid.x[i] - before[i]).norm()); }) / lattice_count;
  }

  // Back to the fill's order (the first step sorts from it, as it would have without the
  // relaxation), with the initial velocities, rest density and zero pressures.
  std::vector<Index> back(n);
  for (std::size_t k = 0; k < n; ++k) back[original[k]] = Index(k);
  fluid.reorder(back);
  for (std::size_t i = 0; i < n; ++i)
  {
    if (fill_kind[i] == FillKind::Explicit) fluid.x[i] = x0[i];
    fluid.v[i] = v0[i];
  }
  std::fill(fluid.rho.begin(), fluid.rho.end(), rho0);
  std::fill(fluid.p_density.begin(), fluid.p_density.end(), Real(0));
  std::fill(fluid.p_divergence.begin(), fluid.p_divergence.end(), Real(0));
  std::fill(fluid.p_total.begin(), fluid.p_total.end(), Real(0));
  bodies.v = body_v;
  bodies.a = body_a;
}

}  // namespace fluid_sim
