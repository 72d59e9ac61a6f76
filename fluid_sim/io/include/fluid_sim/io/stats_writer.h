#pragma once
// stats.csv: one row per time step. The first eleven columns are a contract that scripts read
// by name, in this order:
//   step,t,dt,divergence_iterations,density_iterations,density_error,divergence_error,
//   max_speed,fluid_particles,removed,wall_ms
// More columns follow them (new ones are only ever appended).

#include <cstddef>
#include <fstream>
#include <string>

#include "fluid_sim/core/simulation.h"

namespace fluid_sim
{
namespace io
{
class StatsCsvWriter
{
public:
  /// Creates (truncates) the file and writes the header. Throws std::runtime_error naming the path.
  explicit StatsCsvWriter(const std::string& path);

  /// One row. `step` counts from 1; `wall_ms` is the wall time of the step() call, ms.
  /// Columns: t, dt (s); density_error, divergence_error (relative); max_speed (m/s);
  /// fluid_particles (after the step); removed (this step); then max_density_error (relative),
  /// ms_neighbors, ms_divergence, ms_density (ms), mls_fallbacks, mls_reduced, active_boundary
  /// (boundary particles), divergence_converged, density_converged (0 | 1), kinetic_energy (J),
  /// boundary_pressure_work (J).
  void write(std::size_t step, const StepReport& report, double wall_ms);

  /// Flushes buffered rows; throws std::runtime_error if the file could not be written.
  void flush();

  /// The header line, without its newline.
  static const std::string& header();

private:
  std::string path_;
  std::ofstream out_;
};

}  // namespace io
}  // namespace fluid_sim
