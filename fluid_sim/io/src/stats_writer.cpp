#include "fluid_sim/io/stats_writer.h"

#include <algorithm>
#include <stdexcept>

namespace fluid_sim
{
namespace io
{
const std::string& StatsCsvWriter::header()
{
  static const std::string line =
      "step,t,dt,divergence_iterations,density_iterations,density_error,divergence_error,max_speed,"
      "fluid_particles,removed,wall_ms,"
      "max_density_error,ms_neighbors,ms_divergence,ms_density,mls_fallbacks,mls_reduced,active_boundary,"
      "divergence_converged,density_converged,kinetic_energy,boundary_pressure_work,"
      "coefficient_min,coefficient_max,coefficient_abs_sum_max,coefficient_abs_sum_mean,feedback_ratio_min,"
      "feedback_ratio_max,density_residual_first,density_residual_peak,density_residual_last,wall_guarded,"
      "wall_guard_max_shift";
  return line;
}

StatsCsvWriter::StatsCsvWriter(const std::string& path) : path_(path), out_(path, std::ios::trunc)
{
  if (!out_) throw std::runtime_error("cannot create " + path_);
  out_.precision(9);
  out_ << header() << '\n';
}

void StatsCsvWriter::write(std::size_t step, const StepReport& r, double wall_ms)
{
  out_ << step << ',' << r.time << ',' << r.dt << ',' << r.divergence_iterations << ',' << r.density_iterations << ','
       << r.density_error << ',' << r.divergence_error << ',' << r.max_speed << ',' << r.fluid_particles << ','
       << r.removed << ',' << wall_ms << ',' << r.max_density_error << ',' << r.ms_neighbors << ',' << r.ms_divergence
       << ',' << r.ms_density << ',' << r.mls_fallbacks << ',' << r.mls_reduced << ',' << r.active_boundary << ','
       << int(r.divergence_converged) << ',' << int(r.density_converged) << ',' << r.kinetic_energy << ','
       << r.boundary_pressure_work << ',' << r.coefficient_min << ',' << r.coefficient_max << ','
       << r.coefficient_abs_sum_max << ',' << r.coefficient_abs_sum_mean << ',' << r.feedback_ratio_min << ','
       << r.feedback_ratio_max << ',';
  // The density solve's largest residual per iteration (relative): first, largest, last.
  const std::vector<float>& res = r.density_residual_max;
  if (res.empty())
    out_ << ",,";
  else
    out_ << res.front() << ',' << *std::max_element(res.begin(), res.end()) << ',' << res.back();
  out_ << ',' << r.wall_guarded << ',' << r.wall_guard_max_shift << '\n';
}

void StatsCsvWriter::flush()
{
  out_.flush();
  if (!out_) throw std::runtime_error("cannot write " + path_);
}

}  // namespace io
}  // namespace fluid_sim
