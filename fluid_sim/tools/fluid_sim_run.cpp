// fluid_sim_run: runs a scene headless and writes PLY frames, stats.csv and summary.json, the
// instruments' regions.csv, probes.csv and spill.csv when the scene declares them, bodies.csv
// when it has free bodies, wrenches.csv when it has bodies, sinks.csv when it has sinks and
// emitters.csv when it has emitters;
// with --surface the free surface as a mesh beside each frame (surface/NNNNNN.obj).
//
//   fluid_sim_run SCENE.yaml [--duration S] [--out DIR] [--set key.path=value ...] [--threads N]
//                 [--surface]
//
// Exit codes: 0 ok, 1 I/O or internal error, 2 bad input (scene, option), 3 the run became
// unstable, 130 interrupted (SIGINT). The summary and stats are written in cases 0, 3 and 130.

#include <signal.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <optional>
#include <regex>
#include <stdexcept>
#include <string>
#include <vector>

#include "fluid_sim/core/measurements.h"
#include "fluid_sim/core/simulation.h"
#include "fluid_sim/core/surface.h"
#include "fluid_sim/io/bodies_writer.h"
#include "fluid_sim/io/measurement_writer.h"
#include "fluid_sim/io/obj_writer.h"
#include "fluid_sim/io/ply_writer.h"
#include "fluid_sim/io/run_summary.h"
#include "fluid_sim/io/scene_loader.h"
#include "fluid_sim/io/simulation_output.h"
#include "fluid_sim/io/stats_writer.h"

namespace
{
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr int kExitOk = 0;
constexpr int kExitError = 1;
constexpr int kExitBadInput = 2;
constexpr int kExitUnstable = 3;
constexpr int kExitInterrupted = 130;

volatile sig_atomic_t g_interrupted = 0;

extern "C" void onSigint(int)
{
  g_interrupted = 1;
}

/// The first SIGINT asks the loop to stop after the current step; SA_RESETHAND makes a second
/// one terminate at once.
void installSigintHandler()
{
  struct sigaction action = {};
  action.sa_handler = onSigint;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESETHAND;
  sigaction(SIGINT, &action, nullptr);
}

double secondsSince(Clock::time_point start)
{
  return std::chrono::duration<double>(Clock::now() - start).count();
}

std::string formatDuration(double seconds)
{
  if (!std::isfinite(seconds) || seconds < 0.0) return "--:--";
  const auto total = static_cast<long>(std::lround(seconds));
  char text[32];
  if (total >= 3600)
    std::snprintf(text, sizeof text, "%ld:%02ld:%02ld", total / 3600, total / 60 % 60, total % 60);
  else
    std::snprintf(text, sizeof text, "%ld:%02ld", total / 60, total % 60);
  return text;
}

/// Progress on stderr: on a terminal a bar redrawn at most 5 times per second, otherwise a plain
/// line every 5 % of the duration or every 10 s.
class Progress
{
public:
  explicit Progress(double duration)
      : duration_(duration), terminal_(isatty(STDERR_FILENO) != 0), start_(Clock::now()), last_(start_)
  {
  }

  void update(double t)
  {
    const double since_last = secondsSince(last_);
    if (terminal_)
    {
      if (since_last < 0.2) return;
    }
    else
    {
      const double fraction = duration_ > 0.0 ? t / duration_ + 1.0e-9 : 1.0;
      if (fraction < next_fraction_ && since_last < 10.0) return;
      next_fraction_ = (std::floor(fraction / 0.05) + 1.0) * 0.05;
    }
    last_ = Clock::now();
    print(t);
  }

  void finish(double t)
  {
    if (terminal_)
    {
      print(t);
      std::cerr << '\n';
    }
  }

private:
  void print(double t) const
  {
    const double elapsed = secondsSince(start_);
    const double fraction = duration_ > 0.0 ? std::min(1.0, t / duration_) : 1.0;
    const double rtf = elapsed > 0.0 ? t / elapsed : 0.0;
    const double eta = rtf > 0.0 ? std::max(0.0, duration_ - t) / rtf : -1.0;  // s
    char text[160];
    std::snprintf(text, sizeof text, "%.4g / %.4g s (%3.0f %%)  real-time factor %.3g  ETA %s", t, duration_,
                  100.0 * fraction, rtf, formatDuration(eta).c_str());
    if (terminal_)
    {
      constexpr int kWidth = 30;
      const int filled = static_cast<int>(fraction * kWidth + 1.0e-6);
      std::cerr << "\r[" << std::string(filled, '#') << std::string(kWidth - filled, '-') << "] " << text << "\033[K"
                << std::flush;
    }
    else
    {
      std::cerr << text << std::endl;
    }
  }

  double duration_;  // s
  bool terminal_;
  Clock::time_point start_;
  Clock::time_point last_;
  double next_fraction_ = 0.05;
};

/// Removes frames of an earlier run (NNNNNN.<extension>: ply frames, obj surfaces) so the
/// directory holds one consistent series.
void removeOldFrames(const fs::path& frames_dir, const std::string& extension = "ply")
{
  const std::regex frame_name("[0-9]{6}\\." + extension + "(\\.tmp)?");
  for (const auto& entry : fs::directory_iterator(frames_dir))
    if (entry.is_regular_file() && std::regex_match(entry.path().filename().string(), frame_name))
      fs::remove(entry.path());
}

/// Removes what an earlier run left in the output directory that this run may not write again
/// (its instruments' CSV files, its frames and surfaces, its summary), so that no file beside this
/// run's summary.json holds another run's data. Only the runner's own file names are touched.
void removeOldOutputs(const fs::path& out_dir)
{
  for (const char* name : {"stats.csv", "summary.json", "regions.csv", "probes.csv", "spill.csv", "bodies.csv",
                           "wrenches.csv", "sinks.csv", "emitters.csv", "frames.csv"})
    fs::remove(out_dir / name);
  if (fs::is_directory(out_dir / "frames")) removeOldFrames(out_dir / "frames");
  if (fs::is_directory(out_dir / "surface")) removeOldFrames(out_dir / "surface", "obj");
}

std::string vectorText(const fluid_sim::Vec3d& v)
{
  char text[96];
  std::snprintf(text, sizeof text, "[%.4g, %.4g, %.4g]", v.x(), v.y(), v.z());
  return text;
}

void printSummary(const fluid_sim::io::RunSummary& s, const fluid_sim::FillReport& fill, bool relax_on,
                  double relax_tolerance, const fluid_sim::SolverConfig& solver, const fs::path& out_dir,
                  std::size_t frames)
{
  std::printf("scene    %s (%s, spacing %g m, %d threads)\n", s.scene.c_str(), s.method.c_str(), s.spacing, s.threads);
  std::printf("fluid    %zu particles (%zu at start, %zu removed at start, %zu left the domain), %zu boundary\n",
              s.final_fluid_particles, s.initial_fluid_particles, s.removed_at_start, s.removed_total,
              s.boundary_particles);
  // The lattice before t = 0 (scene key fill): points trimmed at walls, and the relaxation.
  std::printf("fill     %zu lattice points trimmed at walls", fill.trimmed);
  if (fill.overlapped > 0) std::printf(", %zu left out where an earlier block's water lies", fill.overlapped);
  std::printf("; largest density error at t = 0 %.3g %%", 100.0 * fill.final_density_error);
  if (!relax_on) std::printf(" (fill.relax off: not relaxed)");
  if (fill.relaxed)
    std::printf(" (relaxed from %.3g %% in %d pseudo-steps, %.0f ms)", 100.0 * fill.initial_density_error,
                fill.relax_steps, fill.ms_relax);
  std::printf("\n");
  if (!fill.settled && !relax_on)
    std::printf(
        "warning  fill.relax is off and the lattice is %.3g %% from rest density (beyond "
        "fill.relax_tolerance): it starts unsettled and will move at t = 0\n",
        100.0 * fill.final_density_error);
  else if (!fill.settled && fill.final_density_error <= relax_tolerance)
    std::printf(
        "warning  the fill's relaxation stopped at fill.relax_max_steps (%d pseudo-steps) with the water within "
        "fill.relax_tolerance of rest density but still sinking into place: it starts a little unsettled; raise "
        "fill.relax_max_steps\n",
        fill.relax_steps);
  else if (!fill.settled)
    std::printf(
        "warning  the fill's relaxation stopped at fill.relax_max_steps (%d pseudo-steps) before the water "
        "was within fill.relax_tolerance of rest density: it starts unsettled and will move at t = 0; raise "
        "fill.relax_max_steps\n",
        fill.relax_steps);
  std::printf("steps    %zu, %.3f ms/step; simulated %.4g s in %.3g s (real-time factor %.3g)\n", s.steps,
              s.msPerStep(), s.simulated_time, s.wall_time, s.realTimeFactor());
  std::printf("solver   %.2f divergence, %.2f density iterations/step; density error mean %.3g %%, max %.3g %%\n",
              s.mean_divergence_iterations, s.mean_density_iterations, 100.0 * s.mean_density_error,
              100.0 * s.max_density_error);
  // Not an instability (the run goes on), but not the accuracy asked for either: said, with the
  // counts in summary.json (the node marks such steps not_converged in its stats).
  if (s.density_not_converged_steps > 0 || s.divergence_not_converged_steps > 0)
    std::printf(
        "warning  %zu of %zu steps ended the density solve and %zu the divergence solve at solver.max_iterations "
        "(%d) above their tolerances (solver.density_error %.3g %%, divergence_error %.3g %%): the water is more "
        "compressed than asked; raise solver.max_iterations or shorten the time step\n",
        s.density_not_converged_steps, s.steps, s.divergence_not_converged_steps, solver.max_iterations,
        100.0 * solver.density_error, 100.0 * solver.divergence_error);
  // Not a fault either: where the pressure let water run at a wall, the guard held it (Eq. A31).
  if (s.wall_guarded_particles > 0)
    std::printf(
        "guard    the wall guard (solver.wall_guard) held %zu particle steps short of a wall in %zu of %zu steps "
        "(largest correction %.3g mm): the pressure alone let that water run into a wall's layer\n",
        s.wall_guarded_particles, s.wall_guarded_steps, s.steps, 1000.0 * s.wall_guard_max_shift);
  for (const auto& body : s.bodies)
    std::printf("body     %s: mean force %s N, mean torque %s N m\n", body.name.c_str(),
                vectorText(body.mean.force).c_str(), vectorText(body.mean.torque).c_str());
  for (const auto& body : s.free_bodies)
    std::printf("free     %s: centre of mass %s m, velocity %s m/s at the end\n", body.name.c_str(),
                vectorText(body.center_of_mass).c_str(), vectorText(body.linear_velocity).c_str());
  for (const auto& sink : s.sinks)
    std::printf("sink     %s: drained %zu particles, %.6g m^3, %.6g kg\n", sink.name.c_str(), sink.particles,
                sink.volume, sink.mass);
  for (const auto& e : s.emitters)
    std::printf(
        "emitter  %s: released %zu particles, %.6g m^3 (nozzle %zu points at %.6g m/s: %.6g m^3/s), %zu "
        "points blocked%s\n",
        e.name.c_str(), e.particles, e.volume, e.points, e.speed, e.flow_rate, e.blocked,
        e.budget_reached ? ", stopped at its particle budget" : "");
  std::printf("status   %s%s%s\n", s.status.c_str(), s.reason.empty() ? "" : ": ", s.reason.c_str());
  std::printf("output   %s (%zu frames)\n", out_dir.string().c_str(), frames);
}

struct Options
{
  std::string scene;
  double duration = -1.0;  // s; < 0: the scene's duration
  std::string out;
  std::vector<std::string> overrides;
  int threads = 0;       // 0: all cores
  bool surface = false;  // also write surface/NNNNNN.obj beside each frame
};

int run(const Options& options)
{
  using namespace fluid_sim;

  std::unique_ptr<Simulation> sim;
  std::unique_ptr<Measurements> instruments;  // the scene's regions, probes and spill
  try
  {
    const SceneConfig scene = io::loadScene(options.scene, options.overrides);
    for (const std::string& warning : scene.warnings) std::cerr << "warning: " << warning << '\n';
    // A nozzle fixed in a tf frame needs tf: the ROS node's, not the runner's.
    for (std::size_t i = 0; i < scene.emitters.size(); ++i)
      if (!scene.emitters[i].frame.empty())
        throw ConfigError("emitters[" + std::to_string(i) + "].frame",
                          "'" + scene.emitters[i].frame +
                              "' is a tf frame, which only the ROS node follows; give the runner a pose or a body");
    sim = std::make_unique<Simulation>(scene);
    for (const std::string& warning : sim->startWarnings()) std::cerr << "warning: " << warning << '\n';
    instruments = std::make_unique<Measurements>(*sim);  // a region's body must be one of sim's
  }
  catch (const io::SceneError& e)
  {
    std::cerr << "error: " << e.what() << '\n';
    return kExitBadInput;
  }
  catch (const ConfigError& e)  // from Simulation: the scene parsed but cannot be built
  {
    std::cerr << "error: " << options.scene << ": " << e.what() << '\n';
    return kExitBadInput;
  }

  const SceneConfig& scene = sim->scene();
  const double duration = options.duration >= 0.0 ? options.duration : scene.duration;  // s
  const double frame_interval = scene.output.frame_interval;                            // s
  const fs::path out_dir =
      options.out.empty() ? fs::path("out") / fs::path(options.scene).stem() : fs::path(options.out);
  const fs::path frames_dir = out_dir / "frames";
  const fs::path surface_dir = out_dir / "surface";
  fs::create_directories(out_dir);
  removeOldOutputs(out_dir);
  if (frame_interval > 0.0)
  {
    fs::create_directories(frames_dir);
    if (options.surface) fs::create_directories(surface_dir);
  }
  else if (options.surface)
    std::cerr << "warning: --surface writes a mesh beside each PLY frame, and output.frame_interval is 0 (no "
                 "frames): no surface is written\n";

  io::RunStatistics stats(io::bodyNames(*sim));
  io::StatsCsvWriter csv((out_dir / "stats.csv").string());
  std::size_t frames = 0;      // written so far; the next file's number
  std::size_t frame_slot = 0;  // the next frame is due at frame_slot * frame_interval
  // frames.csv: each frame's simulated time. Files are numbered in order; a step longer than
  // frame_interval writes one frame for the multiples it passes, so number x interval is not
  // always the time (a user read frame 20 as 0.02 s; it was 0.1 s).
  std::unique_ptr<std::ofstream> frames_csv;
  if (frame_interval > 0.0)
  {
    frames_csv = std::make_unique<std::ofstream>(out_dir / "frames.csv");
    if (!*frames_csv) throw std::runtime_error("cannot write " + (out_dir / "frames.csv").string());
    *frames_csv << "frame,t,file\n" << std::setprecision(9);
  }
  // --surface: the free surface of each frame (core surface.h, OpenVDB), with the frame's number.
  std::size_t surfaces = 0, surfaces_refused = 0;
  double surface_ms = 0.0, surface_triangles = 0.0;  // summed over the surfaces written
  const auto writeSurface = [&](std::size_t index) {
    try
    {
      const SurfaceMesh mesh = reconstructSurface(sim->positions(), scene.spacing);
      io::writeObj((surface_dir / io::surfaceFileName(index)).string(), mesh);
      ++surfaces;
      surface_ms += mesh.ms;
      surface_triangles += double(mesh.triangles.size());
      if (mesh.skipped_particles > 0)
        std::cerr << "warning: surface " << io::surfaceFileName(index) << ": " << mesh.skipped_particles
                  << " particles with a non-finite position left out\n";
    }
    catch (const ConfigError& e)  // the voxel budget: this frame's surface is left out, the run goes on
    {
      if (surfaces_refused++ == 0)
        std::cerr << "warning: surface " << io::surfaceFileName(index) << " not written: " << e.what() << '\n';
    }
  };
  // Frame k is due at k * frame_interval; it is written after the step that ends nearest to it.
  const auto writeFrameIfDue = [&](double t, double dt, bool force) {
    if (frame_interval <= 0.0 || (!force && t + 0.5 * dt < frame_slot * frame_interval)) return;
    const std::size_t index = frames++;
    io::writePly((frames_dir / io::frameFileName(index)).string(), *sim);
    *frames_csv << index << ',' << t << ",frames/" << io::frameFileName(index) << '\n';
    if (options.surface) writeSurface(index);
    frame_slot = std::max(frame_slot, static_cast<std::size_t>(std::floor((t + 0.5 * dt) / frame_interval)) + 1);
  };
  writeFrameIfDue(sim->time(), 0.0, false);

  // Instruments (regions, probes, spill) and free bodies (bodies.csv): measured at the frame
  // times (frame k after the step that ends nearest to k * frame_interval), and after the last
  // step; without frames (frame_interval 0) at the start and after the last step. A scene with
  // neither measures nothing.
  std::unique_ptr<io::MeasurementCsvWriter> instrument_csv;
  if (!instruments->empty())
    instrument_csv = std::make_unique<io::MeasurementCsvWriter>(out_dir.string(), *instruments);
  std::unique_ptr<io::BodiesCsvWriter> bodies_csv;
  if (io::hasFreeBodies(*sim)) bodies_csv = std::make_unique<io::BodiesCsvWriter>((out_dir / "bodies.csv").string());
  // wrenches.csv: every body's force and torque, time-averaged between the measurements (a force
  // history of a scripted paddle or a tank; summary.json has only the last tenth's mean).
  std::unique_ptr<io::WrenchesCsvWriter> wrenches_csv;
  if (sim->numBodies() > 0)
    wrenches_csv = std::make_unique<io::WrenchesCsvWriter>((out_dir / "wrenches.csv").string(), io::bodyNames(*sim));
  std::unique_ptr<io::SinksCsvWriter> sinks_csv;
  if (!scene.sinks.empty()) sinks_csv = std::make_unique<io::SinksCsvWriter>((out_dir / "sinks.csv").string());
  std::unique_ptr<io::EmittersCsvWriter> emitters_csv;
  if (!scene.emitters.empty())
    emitters_csv = std::make_unique<io::EmittersCsvWriter>((out_dir / "emitters.csv").string());
  std::size_t measure_slot = 0;  // the next measurement is due at measure_slot * frame_interval
  double last_measured = -1.0;   // s, simulated time of the last measurement
  std::size_t measurements = 0;  // of the instruments
  double measure_ms = 0.0;       // wall time of all the instruments' evaluations
  std::optional<io::SpillSummary> spill;
  if (scene.spill.enabled) spill = io::SpillSummary{scene.spill.below, 0, 0.0, 0, 0.0};
  const auto measureIfDue = [&](double t, double dt, bool force) {
    if ((!instrument_csv && !bodies_csv && !wrenches_csv && !sinks_csv && !emitters_csv) || t == last_measured) return;
    if (!force && (frame_interval <= 0.0 || t + 0.5 * dt < measure_slot * frame_interval)) return;
    last_measured = t;
    if (frame_interval > 0.0)
      measure_slot = std::max(measure_slot, static_cast<std::size_t>(std::floor((t + 0.5 * dt) / frame_interval)) + 1);
    if (bodies_csv) bodies_csv->write(t, io::bodyInfos(*sim));
    if (wrenches_csv) wrenches_csv->write(t);
    if (sinks_csv) sinks_csv->write(t, sim->sinkTotals());
    if (emitters_csv) emitters_csv->write(t, sim->emitterTotals());
    if (!instrument_csv) return;
    const auto measure_start = Clock::now();
    const MeasurementReport m = instruments->evaluate(*sim);
    measure_ms += 1000.0 * secondsSince(measure_start);
    ++measurements;
    instrument_csv->write(m);
    if (spill)
    {
      spill->particles = m.spill.particles;
      spill->volume = m.spill.volume;
      spill->max_particles = std::max(spill->max_particles, m.spill.particles);
      spill->max_volume = std::max(spill->max_volume, m.spill.volume);
    }
  };
  measureIfDue(sim->time(), 0.0, true);

  Progress progress(duration);
  std::string status = "ok";
  std::string reason;
  const auto start = Clock::now();
  auto last_flush = start;
  // Step while a step would still end meaningfully before the duration (1e-3 dt absorbs the
  // rounding of a time summed from many steps).
  while (sim->time() < duration - 1.0e-3 * sim->nextTimeStep())
  {
    if (g_interrupted)
    {
      status = "interrupted";
      reason = "interrupted (SIGINT) at t = " + std::to_string(sim->time()) + " s";
      break;
    }
    const auto step_start = Clock::now();
    // The last step ends at the duration (an adaptive step overshot it: 0.600854 s for 0.6). A
    // remainder within rounding of a whole step (a fixed step's time summed over many steps) is
    // a whole step. Where less than two steps are left, the last two share it: a remainder of
    // 2e-5 s taken alone after a 5 ms step made the density solve remove that step's leftover
    // compression in 2e-5 s (pressures ~ 1/dt^2: the tank's force read -312,685 N for 157 N of
    // water, the kinetic energy jumped 100-fold), so the last step is at least half a step.
    const double remaining = duration - sim->time();  // s
    const double next = sim->nextTimeStep();          // s
    const double dt = remaining < (1.0 - 1.0e-6) * next                                        ? remaining
                      : remaining > (1.0 + 1.0e-6) * next && remaining < (2.0 - 1.0e-6) * next ? 0.5 * remaining
                                                                                               : next;
    const StepReport report = sim->step(dt);
    const double wall_ms = 1000.0 * secondsSince(step_start);
    for (const std::string& notice : report.notices) std::cerr << "warning: " << notice << '\n';
    const std::vector<io::Wrench> wrenches = io::bodyWrenches(*sim);
    stats.add(report, wall_ms, wrenches);
    if (wrenches_csv) wrenches_csv->add(wrenches, report.dt);
    csv.write(stats.steps(), report, wall_ms);
    if (report.unstable)
    {
      writeFrameIfDue(report.time, report.dt, true);  // the state that blew up, for inspection
      measureIfDue(report.time, report.dt, true);
      status = "unstable";
      reason = report.reason.empty() ? "unstable" : report.reason;
      break;
    }
    writeFrameIfDue(report.time, report.dt, false);
    measureIfDue(report.time, report.dt, false);
    progress.update(report.time);
    if (secondsSince(last_flush) > 1.0)  // keep stats.csv current for a reader following it
    {
      csv.flush();
      if (instrument_csv) instrument_csv->flush();
      if (bodies_csv) bodies_csv->flush();
      if (wrenches_csv) wrenches_csv->flush();
      if (sinks_csv) sinks_csv->flush();
      if (emitters_csv) emitters_csv->flush();
      if (frames_csv) frames_csv->flush();
      last_flush = Clock::now();
    }
  }
  progress.finish(sim->time());
  csv.flush();
  measureIfDue(sim->time(), 0.0, true);  // the final state (unless just measured)
  if (instrument_csv) instrument_csv->flush();
  if (bodies_csv) bodies_csv->flush();
  if (wrenches_csv) wrenches_csv->flush();
  if (sinks_csv) sinks_csv->flush();
  if (emitters_csv) emitters_csv->flush();

  io::RunSummary summary = io::summarize(*sim, stats);
  summary.threads = options.threads;
  summary.overrides = options.overrides;
  summary.wall_time = secondsSince(start);
  summary.status = status;
  summary.reason = reason;
  summary.spill = spill;
  io::writeSummaryJson((out_dir / "summary.json").string(), summary);
  printSummary(summary, sim->fillReport(), sim->scene().fill.relax, sim->scene().fill.relax_tolerance,
               sim->scene().solver, out_dir, frames);
  if (measurements > 0)
  {
    std::printf("measured %zu times (%.3f ms each)", measurements, measure_ms / double(measurements));
    if (spill)
      std::printf("; spill below %g m: %zu particles (%.4g m^3) at the end", spill->below, spill->particles,
                  spill->volume);
    std::printf("\n");
  }
  if (surfaces > 0 || surfaces_refused > 0)
  {
    std::printf("surface  %zu meshes in %s", surfaces, surface_dir.string().c_str());
    if (surfaces > 0)
      std::printf(" (%.1f ms, %.0f triangles each)", surface_ms / double(surfaces),
                  surface_triangles / double(surfaces));
    if (surfaces_refused > 0) std::printf("; %zu refused (the first one's reason above)", surfaces_refused);
    std::printf("\n");
  }

  if (status == "unstable")
  {
    std::cerr << "unstable at t = " << sim->time() << " s: " << reason << '\n';
    return kExitUnstable;
  }
  if (status == "interrupted")
  {
    std::cerr << reason << '\n';
    return kExitInterrupted;
  }
  return kExitOk;
}

}  // namespace

int main(int argc, char** argv)
{
  CLI::App app{"Runs a fluid_sim scene headless; writes PLY frames, stats.csv and summary.json."};
  Options options;
  app.add_option("scene", options.scene, "Scene YAML file")->required();
  // CLI11's own number checks print their range with DBL_MAX spelled out and let NaN through.
  const CLI::Validator finite_seconds(
      [](std::string& text) {
        char* end = nullptr;
        const double v = std::strtod(text.c_str(), &end);
        if (end == text.c_str() || *end != '\0' || !std::isfinite(v) || v < 0.0)
          return "must be a finite time >= 0 (s), got '" + text + "'";
        return std::string();
      },
      "SECONDS");
  app.add_option("--duration", options.duration, "Simulated time to run, s (default: the scene's duration)")
      ->check(finite_seconds);
  app.add_option("--out", options.out, "Output directory (default: out/<scene stem>)");
  app.add_option("--set", options.overrides, "Override a scene key, e.g. --set solver.boundary_pressure=sph")
      ->allow_extra_args(false);
  app.add_option("--threads", options.threads, "Worker threads, 1 to 1024 (default: all cores)")
      ->check(CLI::Range(1, 1024));
  app.add_flag("--surface", options.surface,
               "Also write the free surface as a triangle mesh beside each PLY frame: surface/NNNNNN.obj");
  try
  {
    app.parse(argc, argv);
  }
  catch (const CLI::ParseError& e)
  {
    const int code = app.exit(e);  // prints help or the usage error
    return code == 0 ? kExitOk : kExitBadInput;
  }

  installSigintHandler();
  if (options.threads <= 0) options.threads = tbb::info::default_concurrency();
  const tbb::global_control threads(tbb::global_control::max_allowed_parallelism,
                                    static_cast<std::size_t>(options.threads));
  try
  {
    return run(options);
  }
  catch (const std::exception& e)
  {
    std::cerr << "error: " << e.what() << '\n';
    return kExitError;
  }
}
