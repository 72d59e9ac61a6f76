#include "fluid_sim/io/run_summary.h"

#include <algorithm>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "fluid_sim/io/file_util.h"

namespace fluid_sim
{
namespace io
{
double RunSummary::realTimeFactor() const
{
  return wall_time > 0.0 ? simulated_time / wall_time : 0.0;
}

double RunSummary::msPerStep() const
{
  return steps > 0 ? 1000.0 * step_time / static_cast<double>(steps) : 0.0;
}

RunStatistics::RunStatistics(std::vector<std::string> body_names) : body_names_(std::move(body_names)) {}

void RunStatistics::add(const StepReport& report, double wall_ms, const std::vector<Wrench>& wrenches)
{
  if (wrenches.size() != body_names_.size())
    throw std::invalid_argument("RunStatistics::add: " + std::to_string(wrenches.size()) + " wrenches for " +
                                std::to_string(body_names_.size()) + " bodies");
  if (times_.empty()) start_time_ = report.time - report.dt;
  times_.push_back(report.time);
  dts_.push_back(report.dt);
  wrenches_.insert(wrenches_.end(), wrenches.begin(), wrenches.end());
  step_ms_ += wall_ms;
  divergence_iterations_ += report.divergence_iterations;
  density_iterations_ += report.density_iterations;
  density_error_sum_ += report.density_error;
  density_error_max_ = std::max(density_error_max_, report.density_error);
  if (!report.density_converged) ++density_not_converged_;
  if (!report.divergence_converged) ++divergence_not_converged_;
  if (report.wall_guarded > 0) ++wall_guarded_steps_;
  wall_guarded_particles_ += report.wall_guarded;
  wall_guard_max_shift_ = std::max(wall_guard_max_shift_, report.wall_guard_max_shift);
}

void RunStatistics::fill(RunSummary& summary) const
{
  const std::size_t n = steps();
  const double per_step = n > 0 ? 1.0 / static_cast<double>(n) : 0.0;
  summary.steps = n;
  summary.simulated_time = n > 0 ? times_.back() : 0.0;
  summary.step_time = step_ms_ / 1000.0;
  summary.mean_divergence_iterations = divergence_iterations_ * per_step;
  summary.mean_density_iterations = density_iterations_ * per_step;
  summary.mean_density_error = density_error_sum_ * per_step;
  summary.max_density_error = density_error_max_;
  summary.density_not_converged_steps = density_not_converged_;
  summary.divergence_not_converged_steps = divergence_not_converged_;
  summary.wall_guarded_steps = wall_guarded_steps_;
  summary.wall_guarded_particles = wall_guarded_particles_;
  summary.wall_guard_max_shift = wall_guard_max_shift_;

  const std::size_t num_bodies = body_names_.size();
  summary.bodies.assign(num_bodies, BodySummary{});
  for (std::size_t b = 0; b < num_bodies; ++b) summary.bodies[b].name = body_names_[b];
  if (n == 0) return;

  const double window_start = times_.back() - 0.1 * (times_.back() - start_time_);  // s
  std::vector<Wrench> sum(num_bodies);
  double weight = 0.0;  // s
  for (std::size_t s = 0; s < n; ++s)
  {
    if (times_[s] - 0.5 * dts_[s] <= window_start && s + 1 < n) continue;
    weight += dts_[s];
    for (std::size_t b = 0; b < num_bodies; ++b)
    {
      sum[b].force += dts_[s] * wrenches_[s * num_bodies + b].force;
      sum[b].torque += dts_[s] * wrenches_[s * num_bodies + b].torque;
    }
  }
  for (std::size_t b = 0; b < num_bodies; ++b)
  {
    summary.bodies[b].last = wrenches_[(n - 1) * num_bodies + b];
    if (weight > 0.0)
      summary.bodies[b].mean = Wrench{sum[b].force / weight, sum[b].torque / weight};
    else
      summary.bodies[b].mean = summary.bodies[b].last;  // a zero-length step
  }
}

namespace
{
nlohmann::ordered_json toJson(const Vec3d& v)
{
  return nlohmann::ordered_json::array({v.x(), v.y(), v.z()});
}
}  // namespace

std::string toJson(const RunSummary& s)
{
  nlohmann::ordered_json bodies = nlohmann::ordered_json::array();
  for (const BodySummary& b : s.bodies)
    bodies.push_back(nlohmann::ordered_json{{"name", b.name},
                                            {"force", toJson(b.last.force)},
                                            {"torque", toJson(b.last.torque)},
                                            {"mean_force", toJson(b.mean.force)},
                                            {"mean_torque", toJson(b.mean.torque)}});
  nlohmann::ordered_json j;
  j["summary_version"] = s.summary_version;
  j["scene"] = s.scene;
  j["overrides"] = s.overrides;
  j["method"] = s.method;
  j["spacing"] = s.spacing;
  j["threads"] = s.threads;
  j["status"] = s.status;
  j["reason"] = s.reason;
  j["fluid_particles"] = {{"initial", s.initial_fluid_particles},
                          {"final", s.final_fluid_particles},
                          {"removed_at_start", s.removed_at_start},
                          {"removed_total", s.removed_total}};
  j["boundary_particles"] = s.boundary_particles;
  j["steps"] = s.steps;
  j["simulated_time_s"] = s.simulated_time;
  j["wall_time_s"] = s.wall_time;
  j["step_time_s"] = s.step_time;
  j["ms_per_step"] = s.msPerStep();
  j["real_time_factor"] = s.realTimeFactor();
  j["mean_divergence_iterations"] = s.mean_divergence_iterations;
  j["mean_density_iterations"] = s.mean_density_iterations;
  j["mean_density_error"] = s.mean_density_error;
  j["max_density_error"] = s.max_density_error;
  j["density_not_converged_steps"] = s.density_not_converged_steps;
  j["divergence_not_converged_steps"] = s.divergence_not_converged_steps;
  j["wall_guarded_steps"] = s.wall_guarded_steps;
  j["wall_guarded_particles"] = s.wall_guarded_particles;
  j["wall_guard_max_shift_m"] = s.wall_guard_max_shift;
  j["bodies"] = bodies;
  j["fill"] = {{"trimmed", s.fill.trimmed},
               {"overlapped", s.fill.overlapped},
               {"relaxed", s.fill.relaxed},
               {"relax_steps", s.fill.relax_steps},
               {"settled", s.fill.settled},
               {"initial_density_error", s.fill.initial_density_error},
               {"final_density_error", s.fill.final_density_error}};
  if (s.spill)
    j["spill"] = {{"below_m", s.spill->below},
                  {"particles", s.spill->particles},
                  {"volume_m3", s.spill->volume},
                  {"max_particles", s.spill->max_particles},
                  {"max_volume_m3", s.spill->max_volume}};
  if (!s.free_bodies.empty())
  {
    nlohmann::ordered_json free = nlohmann::ordered_json::object();
    for (const FreeBodySummary& b : s.free_bodies)
    {
      const Eigen::Quaterniond& q = b.orientation;
      free[b.name] = {{"center_of_mass", toJson(b.center_of_mass)},
                      {"orientation", nlohmann::ordered_json::array({q.x(), q.y(), q.z(), q.w()})},
                      {"linear_velocity", toJson(b.linear_velocity)},
                      {"angular_velocity", toJson(b.angular_velocity)},
                      {"mass", b.mass}};
    }
    j["free_bodies"] = free;
  }
  if (!s.sinks.empty())
  {
    nlohmann::ordered_json sinks = nlohmann::ordered_json::object();
    for (const SinkTotal& k : s.sinks)
      sinks[k.name] = {{"particles", k.particles}, {"volume_m3", k.volume}, {"mass_kg", k.mass}};
    j["sinks"] = sinks;
  }
  if (!s.emitters.empty())
  {
    nlohmann::ordered_json emitters = nlohmann::ordered_json::object();
    for (const EmitterTotal& e : s.emitters)
      emitters[e.name] = {{"particles", e.particles},
                          {"volume_m3", e.volume},
                          {"mass_kg", e.mass},
                          {"blocked", e.blocked},
                          {"flow_rate_m3_s", e.flow_rate},
                          {"speed_m_s", e.speed},
                          {"nozzle_points", e.points},
                          {"budget_reached", e.budget_reached}};
    j["emitters"] = emitters;
  }
  return j.dump(2) + "\n";
}

void writeSummaryJson(const std::string& path, const RunSummary& summary)
{
  writeFileAtomically(path, toJson(summary));
}

}  // namespace io
}  // namespace fluid_sim
