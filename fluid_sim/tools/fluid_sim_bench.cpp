// fluid_sim_bench: times the DFSPH step on a scene, one table row per (spacing, boundary
// pressure method). Measures; it is not a timed test.
//
//   fluid_sim_bench [SCENE.yaml] [--steps N] [--warmup N] [--set key.path=value ...]
//                   [--threads N] [--spacing S ...] [--method NAME ...] [--json FILE]
//
// Each row runs in a fresh Simulation: `warmup` steps that are not measured, then `steps`
// measured ones. Rows run from the coarsest spacing (fewest particles) to the finest, because
// the peak resident set size (getrusage ru_maxrss) is a process-wide maximum that never drops.

#include <sys/resource.h>
#include <unistd.h>

#include <tbb/global_control.h>
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "fluid_sim/core/scene_config.h"
#include "fluid_sim/core/simulation.h"
#include "fluid_sim/core/types.h"
#include "fluid_sim/io/scene_loader.h"

namespace
{
using Clock = std::chrono::steady_clock;

const char* const kDefaultScene = "config/bench_dam_break.yaml";

struct Row
{
  double spacing = 0.0;  // m
  std::string method;
  std::size_t fluid = 0;     // fluid particles after the last measured step
  std::size_t boundary = 0;  // boundary particles
  double setup_s = 0.0;      // s, Simulation construction (sampling, boundary volumes)
  int steps = 0;
  double sim_time = 0.0;                   // s, simulated time at the end
  double dt_mean = 0.0;                    // s, simulated time per measured step (mean)
  double real_time_factor = 0.0;           // simulated s per wall-clock s of step() over the measured steps
  double ms_mean = 0.0;                    // ms wall clock per step() (mean)
  double ms_median = 0.0;                  // ms wall clock per step() (median)
  double divergence_iterations = 0;        // per step (mean)
  double density_iterations = 0;           // per step (mean)
  double pressure_passes = 0;              // passes over the pairs for a^p per step (mean; StepReport)
  double ns_per_particle_iteration = 0.0;  // ns in the two solves / (fluid particles * iterations)
  double ms_neighbors = 0.0;               // ms per step in the neighbour search (mean)
  double ms_solves = 0.0;                  // ms per step in the divergence + density solves (mean)
  double ms_divergence = 0.0;              // ms per step in the divergence solve (mean)
  double ms_density = 0.0;                 // ms per step in the density solve and the integration (mean)
  double density_error = 0.0;              // relative, mean over the measured steps
  double pairs_per_particle = 0.0;         // fluid-fluid + fluid-boundary pairs per fluid particle (mean)
  double ns_per_pair_pass = 0.0;           // ns in the two solves / (pairs x iterations x 2 passes)
  int not_converged = 0;                   // steps with a solve stopped at max_iterations
  int unstable = 0;                        // steps reported unstable
  std::string unstable_reason;             // first reason seen
  long peak_rss_kib = 0;                   // KiB, process peak so far
  double peak_bytes_per_particle = 0.0;    // B, process peak RSS / (fluid + boundary)
  double peak_bytes_per_fluid = 0.0;       // B, process peak RSS / fluid (issue 14's measure)
};

long peakRssKib()
{
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss;  // KiB on Linux
}

double median(std::vector<double> values)
{
  if (values.empty()) return 0.0;
  const std::size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + mid, values.end());
  double m = values[mid];
  if (values.size() % 2 == 0) m = 0.5 * (m + *std::max_element(values.begin(), values.begin() + mid));
  return m;
}

std::string shortestDouble(double value)
{
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.10g", value);
  return buffer;
}

/// The scene of one row: the file, the user's --set overrides, then this row's spacing and method.
fluid_sim::SceneConfig sceneFor(const std::string& scene_path, std::vector<std::string> overrides,
                                std::optional<double> spacing, const std::string& method)
{
  if (spacing) overrides.push_back("spacing=" + shortestDouble(*spacing));
  if (!method.empty()) overrides.push_back("solver.boundary_pressure=" + method);
  return fluid_sim::io::loadScene(scene_path, overrides);
}

Row runOne(const fluid_sim::SceneConfig& scene, int warmup, int steps)
{
  Row row;
  row.spacing = scene.spacing;
  row.method = fluid_sim::toString(scene.solver.boundary_pressure);
  row.steps = steps;

  const auto t0 = Clock::now();
  fluid_sim::Simulation sim(scene);
  row.setup_s = std::chrono::duration<double>(Clock::now() - t0).count();

  for (int i = 0; i < warmup; ++i) sim.step();

  std::vector<double> wall_ms;
  wall_ms.reserve(static_cast<std::size_t>(steps));
  const double t_start = sim.time();  // s
  double sum_div = 0.0, sum_dens = 0.0, sum_nbr = 0.0, sum_solve_ms = 0.0, sum_err = 0.0, sum_passes = 0.0;
  double sum_div_ms = 0.0, sum_dens_ms = 0.0;
  double particle_iterations = 0.0;  // sum over steps of fluid particles * (div + density iterations)
  double pair_passes = 0.0;          // sum over steps of pairs * iterations * 2 (a^p pass + Jacobi pass)
  double sum_pairs_per_particle = 0.0;
  for (int i = 0; i < steps; ++i)
  {
    const auto start = Clock::now();
    const fluid_sim::StepReport report = sim.step();
    wall_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
    sum_div += report.divergence_iterations;
    sum_dens += report.density_iterations;
    sum_passes += report.pressure_passes;
    sum_nbr += report.ms_neighbors;
    sum_solve_ms += report.ms_divergence + report.ms_density;
    sum_div_ms += report.ms_divergence;
    sum_dens_ms += report.ms_density;
    sum_err += report.density_error;
    const double iterations = static_cast<double>(report.divergence_iterations + report.density_iterations);
    particle_iterations += static_cast<double>(report.fluid_particles) * iterations;
    pair_passes += 2.0 * static_cast<double>(report.neighbor_pairs) * iterations;
    sum_pairs_per_particle += static_cast<double>(report.neighbor_pairs) /
                              static_cast<double>(std::max<std::size_t>(report.fluid_particles, 1));
    if (!report.divergence_converged || !report.density_converged) ++row.not_converged;
    if (report.unstable)
    {
      if (row.unstable == 0) row.unstable_reason = report.reason;
      ++row.unstable;
    }
  }

  const double n = std::max(steps, 1);
  row.fluid = sim.numFluidParticles();
  row.boundary = sim.boundaryPositions().size();
  row.sim_time = sim.time();
  double sum_ms = 0.0;
  for (double ms : wall_ms) sum_ms += ms;
  row.ms_mean = sum_ms / n;
  row.dt_mean = (row.sim_time - t_start) / n;
  row.real_time_factor = sum_ms > 0.0 ? (row.sim_time - t_start) / (sum_ms * 1.0e-3) : 0.0;
  row.ms_median = median(wall_ms);
  row.divergence_iterations = sum_div / n;
  row.density_iterations = sum_dens / n;
  row.pressure_passes = sum_passes / n;
  row.ms_neighbors = sum_nbr / n;
  row.ms_solves = sum_solve_ms / n;
  row.ms_divergence = sum_div_ms / n;
  row.ms_density = sum_dens_ms / n;
  row.density_error = sum_err / n;
  row.ns_per_particle_iteration = particle_iterations > 0.0 ? sum_solve_ms * 1.0e6 / particle_iterations : 0.0;
  row.pairs_per_particle = sum_pairs_per_particle / n;
  row.ns_per_pair_pass = pair_passes > 0.0 ? sum_solve_ms * 1.0e6 / pair_passes : 0.0;
  row.peak_rss_kib = peakRssKib();
  const std::size_t particles = row.fluid + row.boundary;
  row.peak_bytes_per_particle =
      particles > 0 ? static_cast<double>(row.peak_rss_kib) * 1024.0 / static_cast<double>(particles) : 0.0;
  row.peak_bytes_per_fluid =
      row.fluid > 0 ? static_cast<double>(row.peak_rss_kib) * 1024.0 / static_cast<double>(row.fluid) : 0.0;
  return row;
}

void printHeader()
{
  std::printf("%8s %-9s %9s %9s %7s %9s %9s %7s %6s %7s %7s %10s %7s %8s %8s %10s %9s %9s %7s\n", "spacing", "method",
              "fluid", "boundary", "setup", "ms/step", "median", "dt", "rtf", "div_it", "dens_it", "ns/(p*it)",
              "pairs/p", "ns/pair", "nbr_ms", "dens_err", "peak_B/p", "peak_B/fl", "flags");
  std::printf("%8s %-9s %9s %9s %7s %9s %9s %7s %6s %7s %7s %10s %7s %8s %8s %10s %9s %9s %7s\n", "m", "", "", "", "s",
              "mean", "", "ms", "", "/step", "/step", "ns", "", "/pass", "/step", "mean", "B", "B", "");
  std::fflush(stdout);
}

void printRow(const Row& r)
{
  std::string flags = "ok";
  if (r.unstable > 0)
    flags = "UNSTABLE";
  else if (r.not_converged > 0)
    flags = "nc=" + std::to_string(r.not_converged);
  std::printf(
      "%8.4f %-9s %9zu %9zu %7.2f %9.3f %9.3f %7.3f %6.3f %7.2f %7.2f %10.2f %7.1f %8.3f %8.3f %10.2e %9.0f %9.0f "
      "%7s\n",
      r.spacing, r.method.c_str(), r.fluid, r.boundary, r.setup_s, r.ms_mean, r.ms_median, r.dt_mean * 1e3,
      r.real_time_factor, r.divergence_iterations, r.density_iterations, r.ns_per_particle_iteration,
      r.pairs_per_particle, r.ns_per_pair_pass, r.ms_neighbors, r.density_error, r.peak_bytes_per_particle,
      r.peak_bytes_per_fluid, flags.c_str());
  std::fflush(stdout);
}

nlohmann::json toJson(const Row& r)
{
  return nlohmann::json{{"spacing_m", r.spacing},
                        {"method", r.method},
                        {"fluid_particles", r.fluid},
                        {"boundary_particles", r.boundary},
                        {"setup_s", r.setup_s},
                        {"steps", r.steps},
                        {"sim_time_s", r.sim_time},
                        {"time_step_mean_s", r.dt_mean},
                        {"real_time_factor", r.real_time_factor},
                        {"ms_per_step_mean", r.ms_mean},
                        {"ms_per_step_median", r.ms_median},
                        {"divergence_iterations_per_step", r.divergence_iterations},
                        {"density_iterations_per_step", r.density_iterations},
                        {"pressure_passes_per_step", r.pressure_passes},
                        {"ns_per_particle_iteration", r.ns_per_particle_iteration},
                        {"ms_neighbors_per_step", r.ms_neighbors},
                        {"ms_solves_per_step", r.ms_solves},
                        {"ms_divergence_per_step", r.ms_divergence},
                        {"ms_density_per_step", r.ms_density},
                        {"density_error_mean", r.density_error},
                        {"pairs_per_particle", r.pairs_per_particle},
                        {"ns_per_pair_pass", r.ns_per_pair_pass},
                        {"steps_not_converged", r.not_converged},
                        {"steps_unstable", r.unstable},
                        {"unstable_reason", r.unstable_reason},
                        {"process_peak_rss_kib", r.peak_rss_kib},
                        {"peak_bytes_per_particle", r.peak_bytes_per_particle},
                        {"peak_bytes_per_fluid_particle", r.peak_bytes_per_fluid}};
}

std::string findDefaultScene()
{
  if (std::ifstream(kDefaultScene).good()) return kDefaultScene;
#ifdef FLUID_SIM_SOURCE_DIR
  const std::string in_source = std::string(FLUID_SIM_SOURCE_DIR) + "/" + kDefaultScene;
  if (std::ifstream(in_source).good()) return in_source;
#endif
  return kDefaultScene;  // loadScene reports the missing file
}

}  // namespace

int main(int argc, char** argv)
{
  CLI::App app{"fluid_sim_bench: time the DFSPH step, one row per spacing and boundary pressure method"};
  std::string scene_path;
  int steps = 200;
  int warmup = 20;
  std::vector<std::string> overrides;
  int threads = 0;
  std::vector<double> spacings;
  std::vector<std::string> methods;
  std::string json_path;
  app.add_option("scene", scene_path, std::string("scene YAML (default: ") + kDefaultScene + ")");
  // CLI11's PositiveNumber and NonNegativeNumber print their range with DBL_MAX spelled out.
  app.add_option("--steps", steps, "measured steps per row")
      ->check(CLI::Range(1, std::numeric_limits<int>::max()))
      ->capture_default_str();
  app.add_option("--warmup", warmup, "unmeasured steps before them")
      ->check(CLI::Range(0, std::numeric_limits<int>::max()))
      ->capture_default_str();
  app.add_option("--set", overrides, "scene override key.path=value (YAML value), repeatable")
      ->allow_extra_args(false)
      ->take_all();
  app.add_option("--threads", threads, "worker threads, 0 to 1024 (0 = all cores)")->check(CLI::Range(0, 1024));
  app.add_option("--spacing", spacings, "particle spacing in m, repeatable (default: the scene's)")
      ->allow_extra_args(false)
      ->take_all()
      ->check(CLI::Validator(
          [](std::string& text) {
            char* end = nullptr;
            const double v = std::strtod(text.c_str(), &end);
            if (end == text.c_str() || *end != '\0' || !std::isfinite(v) || v <= 0.0)
              return "must be a finite length > 0 (m), got '" + text + "'";
            return std::string();
          },
          "METRES"));
  app.add_option("--method", methods,
                 "boundary pressure: mirroring | mirroring_eq2 | sph | mls | all (mirroring, sph and mls), repeatable "
                 "(default: the scene's)")
      ->allow_extra_args(false)
      ->take_all();
  app.add_option("--json", json_path, "also write the rows as JSON to FILE");
  try
  {
    app.parse(argc, argv);
  }
  catch (const CLI::ParseError& e)
  {
    const int code = app.exit(e);  // prints help or the usage error
    return code == 0 ? 0 : 2;      // bad options: 2, as a bad scene (and as fluid_sim_run)
  }

  if (scene_path.empty()) scene_path = findDefaultScene();

  std::vector<std::string> method_list;
  for (const std::string& m : methods)
  {
    if (m == "all")
    {
      for (const char* name : {"mirroring", "sph", "mls"}) method_list.push_back(name);
      continue;
    }
    try
    {
      fluid_sim::parseBoundaryPressureMethod(m, "--method");
    }
    catch (const std::exception& e)
    {
      std::cerr << "fluid_sim_bench: " << e.what() << "\n";
      return 2;
    }
    method_list.push_back(m);
  }
  if (method_list.empty()) method_list.push_back("");  // the scene's own

  // Coarse first: fewer particles, so the monotone peak RSS belongs to the row that set it.
  std::vector<std::optional<double>> spacing_list;
  std::sort(spacings.begin(), spacings.end(), std::greater<double>());
  for (double s : spacings) spacing_list.emplace_back(s);
  if (spacing_list.empty()) spacing_list.emplace_back(std::nullopt);

  std::unique_ptr<tbb::global_control> thread_limit;
  if (threads > 0)
    thread_limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                         static_cast<std::size_t>(threads));
  const std::size_t active_threads = tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism);

  // Load (and validate) every row's scene before running any, so that a bad file, --set or
  // --spacing fails at once with exit code 2, as in fluid_sim_run.
  std::vector<fluid_sim::SceneConfig> scenes;
  try
  {
    for (const auto& spacing : spacing_list)
      for (const std::string& method : method_list) scenes.push_back(sceneFor(scene_path, overrides, spacing, method));
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "fluid_sim_bench: %s\n", e.what());
    return 2;
  }

  // A --json file that cannot be written fails now, not after every row has run (it is written,
  // whole, at the end; nothing is created before).
  if (!json_path.empty())
  {
    const std::filesystem::path file(json_path);
    const std::filesystem::path dir = file.has_parent_path() ? file.parent_path() : std::filesystem::path(".");
    std::error_code ec;
    const bool exists = std::filesystem::exists(file, ec);
    const bool writable = exists ? !std::filesystem::is_directory(file, ec) && ::access(json_path.c_str(), W_OK) == 0
                                 : std::filesystem::is_directory(dir, ec) && ::access(dir.c_str(), W_OK) == 0;
    if (!writable)
    {
      std::fprintf(stderr, "fluid_sim_bench: --json %s: cannot write there (%s)\n", json_path.c_str(),
                   exists ? "not a writable file" : "no writable folder");
      return 1;
    }
  }

  std::printf("fluid_sim_bench: scene %s, Real = %s, %zu threads, %d warm-up + %d measured steps per row\n",
              scene_path.c_str(), sizeof(fluid_sim::Real) == 4 ? "float" : "double", active_threads, warmup, steps);
  for (const std::string& o : overrides) std::printf("  --set %s\n", o.c_str());
  for (const std::string& w : scenes.front().warnings) std::printf("  warning: %s\n", w.c_str());
  std::printf(
      "ms/step: wall clock of Simulation::step(); dt: simulated time per step; rtf: simulated / wall-clock time "
      "of the steps (real-time factor of the solver alone);\nns/(p*it): time in the two solves / (fluid particles x "
      "iterations);\npairs/p: fluid-fluid + fluid-boundary pairs per fluid particle; ns/pair: time in the two solves / "
      "(pairs x iterations x 2 passes);\nnbr_ms: neighbour search per step; dens_err: mean relative density error; "
      "peak_B/p: PROCESS "
      "peak RSS\n(getrusage ru_maxrss, monotone over the run: later rows include earlier ones) / (fluid + boundary "
      "particles); peak_B/fl: the same / fluid particles;\nflags: ok | nc=N (steps with a solve at max_iterations) | "
      "UNSTABLE.\n\n");
  printHeader();

  nlohmann::json json_rows = nlohmann::json::array();
  for (const fluid_sim::SceneConfig& scene : scenes)
  {
    try
    {
      const Row row = runOne(scene, warmup, steps);
      printRow(row);
      if (row.unstable > 0) std::printf("         ^ unstable: %s\n", row.unstable_reason.c_str());
      json_rows.push_back(toJson(row));
    }
    catch (const fluid_sim::ConfigError& e)
    {
      std::fprintf(stderr, "fluid_sim_bench: %s\n", e.what());
      return 2;
    }
    catch (const std::exception& e)
    {
      std::fprintf(stderr, "fluid_sim_bench: %s\n", e.what());
      return 1;
    }
  }

  if (!json_path.empty())
  {
    nlohmann::json doc{{"scene", scene_path},
                       {"real", sizeof(fluid_sim::Real) == 4 ? "float" : "double"},
                       {"threads", active_threads},
                       {"warmup_steps", warmup},
                       {"measured_steps", steps},
                       {"overrides", overrides},
                       {"rss_note", "process peak RSS (ru_maxrss), monotone: rows run coarse to fine"},
                       {"rows", json_rows}};
    std::ofstream out(json_path);
    if (!out)
    {
      std::fprintf(stderr, "fluid_sim_bench: cannot write %s\n", json_path.c_str());
      return 1;
    }
    out << doc.dump(2) << "\n";
  }
  return 0;
}
