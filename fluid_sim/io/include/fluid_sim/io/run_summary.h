#pragma once
// summary.json of a run: what was run, how it went, and the mean wrench on every body.
// RunStatistics accumulates the per-step figures; RunSummary is the plain data written out.

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "fluid_sim/core/simulation.h"
#include "fluid_sim/core/types.h"

namespace fluid_sim
{
namespace io
{
/// Force and torque on a body, world frame, torque about the body origin.
struct Wrench
{
  Vec3d force = Vec3d::Zero();   // N
  Vec3d torque = Vec3d::Zero();  // N m
};

struct BodySummary
{
  std::string name;
  Wrench last;  // the last step          (JSON: force, torque)
  Wrench mean;  // time average over the last tenth of the simulated time (JSON: mean_force, mean_torque)
};

/// The final state of a free body (scene key `dynamic`, or a urdf entry's free_links).
struct FreeBodySummary
{
  std::string name;
  Vec3d center_of_mass = Vec3d::Zero();                             // m, world
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  // body -> world (JSON: [qx, qy, qz, qw])
  Vec3d linear_velocity = Vec3d::Zero();                            // m/s, world, of the centre of mass
  Vec3d angular_velocity = Vec3d::Zero();                           // rad/s, world
  double mass = 0.0;                                                // kg
};

/// Spill over a run (scene key spill): fluid outside every region and below a height, as the
/// runner measured it at its frame times.
struct SpillSummary
{
  double below = 0.0;             // m, world z
  std::size_t particles = 0;      // at the last measurement
  double volume = 0.0;            // m^3, at the last measurement
  std::size_t max_particles = 0;  // the most at any measurement
  double max_volume = 0.0;        // m^3
};

struct RunSummary
{
  int summary_version = 1;             // bumped when a field changes meaning or goes away
  std::string scene;                   // scene file
  std::vector<std::string> overrides;  // --set key=value, as given
  std::string method;                  // boundary pressure: mirroring | sph | mls
  double spacing = 0.0;                // m
  int threads = 0;                     // worker threads allowed
  std::string status = "ok";           // ok | unstable | interrupted
  std::string reason;                  // why not ok; empty when ok

  std::size_t initial_fluid_particles = 0;  // sampled and kept at the start
  std::size_t final_fluid_particles = 0;
  std::size_t removed_at_start = 0;  // lattice points and explicit particles left out (Simulation::removedAtStart)
  std::size_t removed_total = 0;     // left the domain during the run
  std::size_t boundary_particles = 0;

  std::size_t steps = 0;
  double simulated_time = 0.0;              // s
  double wall_time = 0.0;                   // s, the whole run (stepping and output)
  double step_time = 0.0;                   // s, sum over the step() calls
  double mean_divergence_iterations = 0.0;  // per step
  double mean_density_iterations = 0.0;     // per step
  double mean_density_error = 0.0;          // relative, mean over steps of StepReport::density_error
  double max_density_error = 0.0;           // relative, max over steps of StepReport::density_error
  // Steps whose solve stopped at solver.max_iterations above its tolerance (StepReport::
  // density_converged / divergence_converged false): the water more compressed than asked.
  std::size_t density_not_converged_steps = 0;
  std::size_t divergence_not_converged_steps = 0;
  // The wall guard (solver.wall_guard, Eq. A31): steps in which it shortened some particle's step,
  // the sum over the steps of the particles it shortened, the largest correction (m).
  std::size_t wall_guarded_steps = 0;
  std::size_t wall_guarded_particles = 0;
  double wall_guard_max_shift = 0.0;
  std::vector<BodySummary> bodies;
  FillReport fill;  // the fill before t = 0 (JSON: fill {trimmed, relaxed, relax_steps, settled, ...})
  std::optional<SpillSummary> spill;         // only for a scene with a spill key (JSON: spill, else absent)
  std::vector<FreeBodySummary> free_bodies;  // at the end of the run (JSON: free_bodies, absent when empty)
  // What each sink removed over the run (JSON: sinks {NAME: {particles, volume_m3, mass_kg}},
  // absent without sinks).
  std::vector<SinkTotal> sinks;
  // What each emitter released (JSON: emitters {NAME: {particles, volume_m3, mass_kg, blocked,
  // flow_rate_m3_s, speed_m_s, nozzle_points, budget_reached}}, absent without emitters).
  std::vector<EmitterTotal> emitters;

  /// Simulated time per wall time over the whole run (0 before any time has passed).
  double realTimeFactor() const;
  /// Mean wall time of one step() call, ms.
  double msPerStep() const;
};

/// Accumulates step reports and body wrenches over a run.
class RunStatistics
{
public:
  explicit RunStatistics(std::vector<std::string> body_names = {});

  /// One step: its report, the wall time of step() (ms) and the wrench on every body, in the
  /// order of the names given to the constructor (else std::invalid_argument).
  void add(const StepReport& report, double wall_ms, const std::vector<Wrench>& wrenches);

  std::size_t steps() const
  {
    return times_.size();
  }

  /// Fills the step figures of `summary` (steps, simulated_time, step_time, iterations, density
  /// errors, bodies) and leaves the other fields alone. A body's mean wrench is the dt-weighted
  /// mean over the steps whose midpoint lies in the last tenth of the simulated time (at least
  /// the last step).
  void fill(RunSummary& summary) const;

private:
  std::vector<std::string> body_names_;
  std::vector<double> times_;           // s, simulated time after each step
  std::vector<double> dts_;             // s, each step
  std::vector<Wrench> wrenches_;        // N and N m, steps x bodies, row-major
  double start_time_ = 0.0;             // s, simulated time before the first step
  double step_ms_ = 0.0;                // ms, sum of wall_ms
  double divergence_iterations_ = 0.0;  // sum over the steps
  double density_iterations_ = 0.0;     // sum over the steps
  double density_error_sum_ = 0.0;      // relative, sum over the steps
  double density_error_max_ = 0.0;      // relative
  std::size_t density_not_converged_ = 0;
  std::size_t divergence_not_converged_ = 0;
  std::size_t wall_guarded_steps_ = 0;
  std::size_t wall_guarded_particles_ = 0;
  double wall_guard_max_shift_ = 0.0;  // m
};

/// The summary as pretty-printed JSON text. Keys: summary_version, scene, overrides, method,
/// spacing (m), threads, status, reason, fluid_particles {initial, final, removed_at_start,
/// removed_total}, boundary_particles, steps, simulated_time_s, wall_time_s, step_time_s,
/// ms_per_step, real_time_factor, mean_divergence_iterations, mean_density_iterations,
/// mean_density_error, max_density_error, density_not_converged_steps,
/// divergence_not_converged_steps, wall_guarded_steps, wall_guarded_particles,
/// wall_guard_max_shift_m, bodies [{name, force [N], torque [N m], mean_force,
/// mean_torque}] (world frame, torque about the body origin), for a scene with a spill key
/// spill {below_m, particles, volume_m3, max_particles, max_volume_m3}, and for a scene with free
/// bodies free_bodies {NAME: {center_of_mass [m], orientation [qx, qy, qz, qw], linear_velocity
/// [m/s], angular_velocity [rad/s], mass [kg]}} (world frame, the final state).
std::string toJson(const RunSummary& summary);

/// Writes toJson(summary) to `path` (through a temporary file and a rename). Throws
/// std::runtime_error naming the path.
void writeSummaryJson(const std::string& path, const RunSummary& summary);

}  // namespace io
}  // namespace fluid_sim
