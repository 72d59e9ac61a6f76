#pragma once
// The simulation facade: built from a SceneConfig, advanced with step(), read through
// accessors. Used by the headless runner, the benchmark, the tests and the ROS node.

#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "fluid_sim/core/emitters.h"
#include "fluid_sim/core/scene_config.h"
#include "fluid_sim/core/types.h"

namespace fluid_sim
{
/// What one step did. step() never throws for a hard physical state; it reports it here.
struct StepReport
{
  double time = 0.0;  // s, simulated time after the step
  double dt = 0.0;    // s, the step just taken
  int divergence_iterations = 0;
  int density_iterations = 0;
  bool divergence_converged = true;
  bool density_converged = true;
  double divergence_error = 0.0;   // mean relative density change per step (positive part)
  double density_error = 0.0;      // mean relative density error (positive part), final
  double max_density_error = 0.0;  // max relative (rho - rho0)/rho0 at the start of the step
  double max_speed = 0.0;          // m/s after the step
  double kinetic_energy = 0.0;     // J, of the fluid after the step
  // J: work done on the fluid this step by the boundary-pressure part of the wall term,
  // -sum_b psi_b (p_b/rho0^2) grad W_ib (Eq. 1 of docs/method.md; with mirroring p_b = p_i, Eq. 2): its
  // velocity change from both solves dotted with m v after the step (the displacement is dt v).
  // The other wall term, (p_i/rho_i^2) grad_b, is the adjoint of the discrete divergence; this
  // one is conservative only while p_b is a fixed field on the wall (sph, mls near rest), not when
  // it follows each fluid particle's own pressure (mirroring). A diagnostic; see method_notes.
  double boundary_pressure_work = 0.0;
  std::size_t fluid_particles = 0;  // after the step
  std::size_t removed = 0;          // particles that left the domain during this step
  std::size_t drained = 0;          // particles removed by the scene's sinks after this step
  std::size_t emitted = 0;          // particles the scene's emitters released after this step
  std::size_t mls_fallbacks = 0;    // boundary particles using Eq. 16 this step (MLS only)
  std::size_t mls_reduced = 0;      // boundary particles with a pseudo-inverse fit (MLS only)
  std::size_t active_boundary = 0;  // boundary particles with a fluid neighbour
  // The wall guard (solver.wall_guard, Eq. A31): fluid particles whose step it shortened (each
  // would have ended closer to a wall's particle layer than the guard distance), and the largest
  // correction (m). Water that stays off its walls reads 0: more means the pressure solve let
  // particles run at a wall (fast water, a large cfl, a loose tolerance, thin walls).
  std::size_t wall_guarded = 0;
  double wall_guard_max_shift = 0.0;
  // The extrapolation p_b = sum_f c_bf p_f (sph, mls) this step, over the active boundary
  // particles: the smallest and largest coefficient c_bf, and the largest and mean sum_f |c_bf|
  // (how much the fit amplifies noise in the fluid pressures; 1 for weighted averages).
  double coefficient_min = 0.0;
  double coefficient_max = 0.0;
  double coefficient_abs_sum_max = 0.0;
  double coefficient_abs_sum_mean = 0.0;
  // The extrapolation's feedback on the Jacobi diagonal (Eq. A4b), as the ratio of the diagonal
  // with it to the diagonal without it, over the fluid particles next to a wall: smallest and
  // largest (1 = no feedback; mirroring's is always included and not reported here).
  double feedback_ratio_min = 1.0;
  double feedback_ratio_max = 1.0;
  // Per iteration of the density solve: the largest relative residual |s_i - D_i| dt^2/rho0 over
  // the particles where the constraint is active (compression left, or a pressure acting; not
  // the free surface's under-dense particles, whose pressure is clamped at zero). The mean,
  // Eq. A9, is density_error. A Jacobi iteration that diverges somewhere shows here first.
  std::vector<float> density_residual_max;
  std::size_t neighbor_pairs = 0;  // fluid-fluid + fluid-boundary pairs in this step's lists
  // Evaluations of the pressure acceleration (Eq. 1, a pass over the pairs each) in both solves:
  // iterations + 1 per solve (each iteration's, and the final one), one fewer for a solve that
  // starts from zero (the first a^p is then zero, or, for SPH's density solve with its hydrostatic
  // p_b, the wall term alone, summed over the fluid-boundary pairs only). Each iteration also
  // makes one Jacobi sweep over the pairs (Eq. A7).
  int pressure_passes = 0;
  bool unstable = false;
  std::string reason;                // why unstable
  std::vector<std::string> notices;  // said once, in the step it happened: a free body that left the domain
  // Wall-clock split of the step, ms.
  double ms_total = 0.0;
  double ms_neighbors = 0.0;
  double ms_divergence = 0.0;
  double ms_density = 0.0;
};

/// What the construction did to the box blocks' lattices before t = 0 (scene key `fill`;
/// docs/method.md, Initial fluid, Eqs. A21-A23).
struct FillReport
{
  std::size_t trimmed = 0;     // lattice points left out for lying closer than a spacing to a wall (Eq. A21)
  std::size_t overlapped = 0;  // lattice points left out where an earlier fluid block's water lies
  // Largest relative density error (rho - rho0)/rho0 (Eq. A1) over the lattice particles at
  // t = 0, before and after the relaxation (equal when it was not needed or fill.relax is off;
  // both 0 without lattice particles, when it is not computed).
  double initial_density_error = 0.0;
  double final_density_error = 0.0;
  bool relaxed = false;  // the initial error exceeded fill.relax_tolerance: the lattice was relaxed
  int relax_steps = 0;   // pseudo-steps taken (Eq. A22)
  // False when the relaxation stopped at fill.relax_max_steps before the lattice was within
  // fill.relax_tolerance of rest density and held (Eq. A23): the water starts unsettled and will
  // move at t = 0; with fill.relax off, when the lattice is beyond the tolerance. True when
  // settled or not needed.
  bool settled = true;
  double ms_relax = 0.0;  // wall-clock time of the check and the relaxation, ms
};

/// Read-only view of one boundary body.
struct BodyInfo
{
  std::string name;
  bool inside = false;
  bool moving = false;
  std::size_t first_particle = 0;  // range in boundaryPositions()
  std::size_t num_particles = 0;
  Pose pose;                          // current body -> world
  Vec3d linear_velocity;              // m/s of the body origin
  Vec3d angular_velocity;             // rad/s, world frame
  Vec3d force;                        // N, world frame, exerted by the fluid in the last step
  Vec3d torque;                       // N m, world frame, about the body origin
  Vec3d force_body;                   // N, the same force in the body frame
  Vec3d torque_body;                  // N m, the same torque in the body frame
  std::size_t contact_particles = 0;  // boundary particles with a fluid neighbour
  double max_pressure = 0.0;          // Pa, largest boundary pressure used (density solve)
  // Free bodies (key `dynamic`); for the others free is false, mass 0 and the centre of mass the
  // body origin.
  bool free = false;
  double mass = 0.0;                     // kg
  Mat3d inertia = Mat3d::Zero();         // kg m^2, about the centre of mass, body axes
  Vec3d center_of_mass = Vec3d::Zero();  // m, world
  Vec3d com_velocity = Vec3d::Zero();    // m/s, world, of the centre of mass
  Vec3d torque_com = Vec3d::Zero();      // N m, world, the fluid's torque about the centre of mass
  Vec3d contact_force = Vec3d::Zero();   // N, world, from contacts with other bodies in the last step
};

/// What a sink (scene key sinks) has removed since t = 0.
struct SinkTotal
{
  std::string name;
  std::size_t particles = 0;
  double volume = 0.0;  // m^3, particles times spacing^3 (the volume each stands for)
  double mass = 0.0;    // kg
};

class Simulation
{
public:
  /// Validates the scene, samples bodies and fluid. Throws ConfigError on bad input.
  explicit Simulation(const SceneConfig& scene);
  ~Simulation();
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  /// Advances by one time step (fixed, or CFL-adaptive), or by `max_dt` (s) when that is shorter:
  /// a run that must end at a given time takes its last step short (the runner's --duration).
  StepReport step(double max_dt = std::numeric_limits<double>::infinity());

  /// Poses an externally driven body (`external: true`) for the next step: `pose` is its pose at
  /// time(), the start of that step. Its velocity follows from the change of pose since the
  /// previous one (zero for the first); a step without a new pose holds it still (zero velocity). `jump` = true places
  /// it without deriving a velocity (velocity zero): for a pose after a pause or a reset, which is not a motion over
  /// one step. `index` from bodyIndex(). A pose with a NaN or infinite component throws
  /// std::invalid_argument naming the body (which keeps its last pose).
  void setBodyPose(std::size_t index, const Pose& pose, bool jump = false);
  /// Index of the body with this name; throws ConfigError if there is none.
  std::size_t bodyIndex(const std::string& name) const;

  /// Settings that may change between steps (the ROS node's dynamic_reconfigure): solver
  /// tolerances and iteration limits, warm start, omega, viscosity and stability limits. The
  /// boundary pressure method and the MLS fit settings are fixed at construction; a different
  /// value for them, or one that fails validate(), throws ConfigError naming the key and leaves
  /// the simulation unchanged.
  void updateSettings(const SolverConfig& solver, const ViscosityConfig& viscosity, const StabilityConfig& stability);

  double time() const;
  /// The time step the next step() will take, s.
  double nextTimeStep() const;
  const SceneConfig& scene() const;

  std::size_t numFluidParticles() const;
  const std::vector<Vec3>& positions() const;   // m
  const std::vector<Vec3>& velocities() const;  // m/s
  /// Pa: the pressure that acted on each particle during the last step, the sum of the
  /// divergence-solve and density-solve pressures (each moves the velocity by dt a^p(p)).
  /// At rest this is the hydrostatic pressure; either part alone is not.
  const std::vector<Real>& pressures() const;
  const std::vector<Real>& densitySolvePressures() const;     // Pa
  const std::vector<Real>& divergenceSolvePressures() const;  // Pa
  const std::vector<Real>& densities() const;                 // kg/m^3

  std::size_t numBodies() const;
  BodyInfo body(std::size_t index) const;
  const std::vector<Vec3>& boundaryPositions() const;   // m, world
  const std::vector<Vec3>& boundaryVelocities() const;  // m/s, world, at time()
  const std::vector<Real>& boundaryPressures() const;   // Pa, last density-solve values (0 for mirroring)
  const std::vector<Real>& boundaryVolumes() const;     // m^3

  std::size_t initialFluidParticles() const;  // sampled fluid particles kept at start
  /// Lattice points and explicit particles dropped at start: inside solids, outside containers,
  /// on open shells, (lattice points) trimmed next to a wall (Eq. A21) or (explicit particles)
  /// outside the domain.
  std::size_t removedAtStart() const;
  /// The trimming and relaxation of the lattices before t = 0.
  const FillReport& fillReport() const;
  /// What the build found suspicious in the scene's start, one line each (free bodies that start
  /// overlapping another body or outside every container, or too light, BodySet::startWarnings();
  /// fluid blocks whose whole-spacing lattice leaves much of them empty, FillResult::warnings):
  /// the runner prints them, the node logs them.
  const std::vector<std::string>& startWarnings() const;
  std::size_t removedTotal() const;  // particles that left the domain since start (sinks not counted)
  /// Per sink of the scene, in its order: what it removed since t = 0.
  const std::vector<SinkTotal>& sinkTotals() const;
  /// Per scene emitter, in its order: what it released since t = 0 (emitters.h).
  const std::vector<EmitterTotal>& emitterTotals() const;
  /// Poses an emitter the caller moves (EmitterConfig::externally_posed: the node's `frame`):
  /// nozzle frame -> world, used from the next step on. Throws ConfigError for an emitter that
  /// is not posed from outside, std::invalid_argument for a non-finite pose.
  void setEmitterPose(std::size_t index, const Pose& pose);
  /// The nozzle frame -> world of an emitter now (an attached one at its body's pose).
  Pose emitterPose(std::size_t index) const;
  double particleMass() const;  // kg

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace fluid_sim
