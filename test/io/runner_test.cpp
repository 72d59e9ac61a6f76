// End-to-end tests of the headless runner (FLUID_SIM_RUN) on a tiny scene: 64 fluid particles,
// 100 steps, well under a second per run.

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "fluid_sim/core/simulation.h"
#include "fluid_sim/io/scene_loader.h"
#include "temp_dir.h"

namespace fluid_sim
{
namespace
{
namespace fs = std::filesystem;

const char* const kTinyScene = R"yaml(
spacing: 0.05
domain: {min: [-0.1, -0.1, -0.1], max: [0.5, 0.5, 0.6]}
time_step: {fixed: 0.002}
duration: 0.2
fluid:
  - box: {min: [0.05, 0.05, 0.05], max: [0.25, 0.25, 0.25]}
boundaries:
  - name: tank
    box: {min: [0, 0, 0], max: [0.4, 0.4, 0.5]}
    inside: true
  - name: ball
    sphere: {center: [0.3, 0.3, 0.1], radius: 0.05}
output: {frame_interval: 0.05}
)yaml";

/// kTinyScene turned into still water 0.15 m deep in its tank alone, at 4 ms steps, no frames:
/// runner arguments (before --out and --duration).
const std::string kStillWater =
    "tiny.yaml --threads 1 --set time_step.fixed=0.004 --set output.frame_interval=0 "
    "--set 'fluid[0].box={min: [0, 0, 0], max: [0.4, 0.4, 0.15]}' --set 'boundaries=[{name: tank, box: {min: [0, 0, "
    "0], max: [0.4, 0.4, 0.5]}, inside: true}]'";

using test::RunResult;

RunResult run(const test::TempDir& dir, const std::string& args)
{
  return test::runRunner(dir, args);
}

nlohmann::json readJson(const std::string& path)
{
  return nlohmann::json::parse(test::readFile(path));
}

std::size_t lineCount(const std::string& path)
{
  const std::string text = test::readFile(path);
  return static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n'));
}

TEST(Runner, RunsTinySceneIntoDefaultOutputDirectory)
{
  test::TempDir dir;
  dir.write("tiny.yaml", kTinyScene);
  const RunResult r = run(dir, "tiny.yaml --threads 1");
  ASSERT_EQ(r.exit_code, 0) << r.err;

  const fs::path out = dir.path() / "out" / "tiny";  // default: out/<scene stem>
  const nlohmann::json summary = readJson((out / "summary.json").string());
  EXPECT_EQ(summary["status"], "ok");
  EXPECT_EQ(summary["scene"], "tiny.yaml");
  EXPECT_EQ(summary["threads"], 1);
  EXPECT_EQ(summary["steps"], 100);
  EXPECT_NEAR(summary["simulated_time_s"].get<double>(), 0.2, 1e-9);
  EXPECT_EQ(summary["fluid_particles"]["initial"], 64);
  EXPECT_GT(summary["boundary_particles"].get<int>(), 0);
  ASSERT_EQ(summary["bodies"].size(), 2u);
  EXPECT_EQ(summary["bodies"][0]["name"], "tank");
  // A box tank on the lattice: nothing trimmed, nothing to relax, settled.
  EXPECT_EQ(summary["fill"]["trimmed"], 0);
  EXPECT_EQ(summary["fill"]["relaxed"], false);
  EXPECT_EQ(summary["fill"]["settled"], true);
  // The tank carries the water: its mean force points down.
  EXPECT_LT(summary["bodies"][0]["mean_force"][2].get<double>(), 0.0);

  EXPECT_EQ(lineCount((out / "stats.csv").string()), 101u);  // header + one row per step
  for (int k = 0; k <= 4; ++k)                               // t = 0, 0.05, ..., 0.2 s
    EXPECT_TRUE(fs::exists(out / "frames" / ("00000" + std::to_string(k) + ".ply"))) << k;
  EXPECT_FALSE(fs::exists(out / "frames" / "000005.ply"));
  // frames.csv gives each frame's time: here every 0.05 s.
  EXPECT_EQ(test::readFile((out / "frames.csv").string()),
            "frame,t,file\n0,0,frames/000000.ply\n1,0.05,frames/000001.ply\n2,0.1,frames/000002.ply\n3,0.15,"
            "frames/000003.ply\n4,0.2,frames/000004.ply\n");
  EXPECT_NE(r.out.find("status   ok"), std::string::npos) << r.out;
}

TEST(Runner, FramesCsvGivesTheTimeOfFramesWrittenLessOftenThanAsked)
{
  // Steps of 2 ms and frames asked every 1 ms: one frame per step, numbered in order, so a
  // frame's number times the interval is not its time (a user read frame 20 as 0.02 s; it was
  // at 0.04 s); frames.csv says when each was written.
  test::TempDir dir;
  dir.write("tiny.yaml", kTinyScene);
  const RunResult r = run(dir, "tiny.yaml --out f --threads 1 --duration 0.04 --set output.frame_interval=0.001");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::istringstream in(test::readFile(dir.file("f/frames.csv")));
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "frame,t,file");
  int rows = 0;
  while (std::getline(in, line))
  {
    std::istringstream row(line);
    std::string frame, t, file;
    std::getline(row, frame, ',');
    std::getline(row, t, ',');
    std::getline(row, file, ',');
    EXPECT_EQ(std::stoi(frame), rows);
    EXPECT_NEAR(std::stod(t), 0.002 * rows, 1e-12) << line;
    EXPECT_TRUE(fs::exists(dir.path() / "f" / file)) << file;
    ++rows;
  }
  EXPECT_EQ(rows, 21);  // t = 0 and after each of the 20 steps
}

TEST(Runner, OverridesAndDuration)
{
  test::TempDir dir;
  dir.write("tiny.yaml", kTinyScene);
  const RunResult r = run(dir,
                          "tiny.yaml --out result --duration 0.04 --set time_step.fixed=0.004 "
                          "--set output.frame_interval=0 --set solver.boundary_pressure=sph");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json summary = readJson(dir.file("result/summary.json"));
  EXPECT_EQ(summary["steps"], 10);
  EXPECT_EQ(summary["method"], "sph");
  EXPECT_EQ(summary["overrides"].size(), 3u);
  EXPECT_FALSE(fs::exists(dir.path() / "result" / "frames"));

  // A duration that is no whole number of steps ends on it: the last step is taken short (an
  // adaptive run asked for 0.6 s simulated 0.600854 s).
  const RunResult fixed = run(dir, "tiny.yaml --out odd --duration 0.041 --set time_step.fixed=0.004");
  ASSERT_EQ(fixed.exit_code, 0) << fixed.err;
  const nlohmann::json odd = readJson(dir.file("odd/summary.json"));
  EXPECT_EQ(odd["steps"], 11);
  EXPECT_NEAR(odd["simulated_time_s"].get<double>(), 0.041, 1e-12);
  const RunResult adaptive = run(dir, "tiny.yaml --out cfl --duration 0.1 --set 'time_step={cfl: 0.4}'");
  ASSERT_EQ(adaptive.exit_code, 0) << adaptive.err;
  EXPECT_NEAR(readJson(dir.file("cfl/summary.json"))["simulated_time_s"].get<double>(), 0.1, 1e-12);
}

TEST(Runner, TheLastTwoStepsShareARemainderSoNoStepIsTiny)
{
  // Still water; --duration 0.20002 with 4 ms steps left a last step of 2e-5 s, in which the
  // density solve removed the leftover compression of a whole step: the tank's force read
  // -312,685 N for 157 N of water (another scene), with status ok.
  test::TempDir dir;
  dir.write("tiny.yaml", kTinyScene);
  const RunResult whole = run(dir, kStillWater + " --out whole --duration 0.2");
  ASSERT_EQ(whole.exit_code, 0) << whole.err;
  const RunResult odd = run(dir, kStillWater + " --out odd --duration 0.20002");
  ASSERT_EQ(odd.exit_code, 0) << odd.err;
  const nlohmann::json a = readJson(dir.file("whole/summary.json"));
  const nlohmann::json b = readJson(dir.file("odd/summary.json"));
  EXPECT_NEAR(b["simulated_time_s"].get<double>(), 0.20002, 1e-12);
  // The last two steps are 2.01 ms each.
  std::istringstream in(test::readFile(dir.file("odd/stats.csv")));
  std::string line;
  std::getline(in, line);
  double smallest = 1.0;
  while (std::getline(in, line))
  {
    std::istringstream row(line);
    std::string step, t, dt;
    std::getline(row, step, ',');
    std::getline(row, t, ',');
    std::getline(row, dt, ',');
    smallest = std::min(smallest, std::stod(dt));
  }
  EXPECT_NEAR(smallest, 0.5 * (0.20002 - 0.196), 1e-9);
  // The tank's force in the last step stays that of still water (about its weight).
  const double weight_force = a["bodies"][0]["force"][2].get<double>();  // N, the last whole step's
  ASSERT_LT(weight_force, 0.0);
  EXPECT_NEAR(b["bodies"][0]["force"][2].get<double>() / weight_force, 1.0, 0.25);
}

TEST(Runner, SolvesStoppedAtMaxIterationsAreCountedAndSaid)
{
  // One iteration per solve cannot reach 0.1 %: the water sank 8 mm and read 0.825 rho g h at a
  // probe, with status ok and nothing said (the node's stats say not_converged per step).
  test::TempDir dir;
  dir.write("tiny.yaml", kTinyScene);
  const std::string still = kStillWater + " --duration 0.2";
  const RunResult r = run(dir, still +
                                   " --out nc --set solver.max_iterations=1 --set solver.min_iterations=0 "
                                   "--set solver.min_divergence_iterations=0");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json s = readJson(dir.file("nc/summary.json"));
  EXPECT_EQ(s["status"], "ok");  // not an instability: the run goes on
  EXPECT_GT(s["density_not_converged_steps"].get<int>(), 0);
  EXPECT_LE(s["density_not_converged_steps"].get<int>(), s["steps"].get<int>());
  EXPECT_NE(r.out.find("steps ended the density solve"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("at solver.max_iterations (1)"), std::string::npos) << r.out;
  // The defaults converge here: no count, no warning.
  const RunResult plain = run(dir, still + " --out ok");
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  EXPECT_EQ(readJson(dir.file("ok/summary.json"))["density_not_converged_steps"], 0);
  EXPECT_EQ(plain.out.find("steps ended the density solve"), std::string::npos) << plain.out;
}

TEST(Runner, TheWallGuardsWorkIsCountedAndSaid)
{
  // Still water at 4 ms steps: mirroring's wall lets it sink towards the floor's layer, where the
  // guard (solver.wall_guard 0.5) holds it; MLS keeps it off, and the guard never acts.
  test::TempDir dir;
  dir.write("tiny.yaml", kTinyScene);
  const std::string still = kStillWater + " --duration 0.2 --set solver.wall_guard=0.5";
  const RunResult r = run(dir, still + " --out mirroring --set solver.boundary_pressure=mirroring");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json s = readJson(dir.file("mirroring/summary.json"));
  const std::size_t guarded = s["wall_guarded_particles"].get<std::size_t>();
  EXPECT_GT(guarded, 0u);
  EXPECT_GT(s["wall_guarded_steps"].get<std::size_t>(), 0u);
  EXPECT_GT(s["wall_guard_max_shift_m"].get<double>(), 0.0);
  EXPECT_LT(s["wall_guard_max_shift_m"].get<double>(), 0.02);  // under a spacing
  EXPECT_NE(r.out.find("guard    the wall guard (solver.wall_guard) held " + std::to_string(guarded)),
            std::string::npos)
      << r.out;
  // stats.csv's wall_guarded column (the second to last) adds up to the summary's count.
  std::istringstream lines(test::readFile(dir.file("mirroring/stats.csv")));
  std::string line;
  std::getline(lines, line);
  ASSERT_EQ(line.substr(line.size() - 34), ",wall_guarded,wall_guard_max_shift") << line;
  std::size_t sum = 0;
  while (std::getline(lines, line))
  {
    const std::size_t last = line.rfind(','), before = line.rfind(',', last - 1);
    sum += std::stoul(line.substr(before + 1, last - before - 1));
  }
  EXPECT_EQ(sum, guarded);
  const RunResult mls = run(dir, still + " --out mls --set solver.boundary_pressure=mls");
  ASSERT_EQ(mls.exit_code, 0) << mls.err;
  EXPECT_EQ(readJson(dir.file("mls/summary.json"))["wall_guarded_particles"], 0);
  EXPECT_EQ(mls.out.find("wall guard"), std::string::npos) << mls.out;
}

TEST(Runner, WritesEveryBodysWrenchHistory)
{
  // wrenches.csv: each body's force and torque averaged between the measurement times (a force
  // history; summary.json has only the mean over the last tenth, which the last window here is).
  test::TempDir dir;
  dir.write("tiny.yaml", kTinyScene);
  const RunResult r = run(dir, "tiny.yaml --out w --threads 1 --set output.frame_interval=0.02");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::istringstream in(test::readFile(dir.file("w/wrenches.csv")));
  std::string line;
  ASSERT_TRUE(std::getline(in, line));
  EXPECT_EQ(line, "t,body,fx,fy,fz,tx,ty,tz,window_s");
  std::vector<std::vector<double>> tank;  // t, fx .. tz, window
  std::size_t rows = 0;
  double window_sum = 0.0;
  while (std::getline(in, line))
  {
    ++rows;
    std::vector<std::string> f;
    std::stringstream cells(line);
    for (std::string c; std::getline(cells, c, ',');) f.push_back(c);
    ASSERT_EQ(f.size(), 9u) << line;
    if (f[1] != "tank") continue;
    std::vector<double> v;
    for (std::size_t k = 0; k < f.size(); ++k)
      if (k != 1) v.push_back(std::stod(f[k]));
    window_sum += v.back();
    tank.push_back(v);
  }
  EXPECT_EQ(rows, 2u * 10u);  // two bodies, one row each per 0.02 s (none at t = 0)
  ASSERT_EQ(tank.size(), 10u);
  EXPECT_NEAR(window_sum, 0.2, 1e-9);
  EXPECT_NEAR(tank.back()[0], 0.2, 1e-9);
  const nlohmann::json summary = readJson(dir.file("w/summary.json"));
  for (int k = 0; k < 3; ++k)
    EXPECT_NEAR(tank.back()[1 + k], summary["bodies"][0]["mean_force"][k].get<double>(),
                1e-6 * (1.0 + std::abs(tank.back()[1 + k])))
        << k;
}

TEST(Runner, SurfaceWritesAnObjBesideEveryFrameWithItsNumber)
{
  test::TempDir dir;
  dir.write("tiny.yaml", kTinyScene);
  const RunResult plain = run(dir, "tiny.yaml --out plain --threads 1");
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  EXPECT_FALSE(fs::exists(dir.path() / "plain" / "surface"));  // nothing without --surface
  // A stale surface of an earlier run is removed, as stale frames are.
  fs::create_directories(dir.path() / "with" / "surface");
  dir.write("with/surface/000099.obj", "# stale\n");
  const RunResult r = run(dir, "tiny.yaml --out with --threads 1 --surface");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_FALSE(fs::exists(dir.path() / "with" / "surface" / "000099.obj"));
  // The frames' times and numbers: t = 0, 0.05, ..., 0.2 s as 000000 ... 000004.
  std::vector<std::string> frames, surfaces;
  for (const auto& e : fs::directory_iterator(dir.path() / "with" / "frames")) frames.push_back(e.path().stem());
  for (const auto& e : fs::directory_iterator(dir.path() / "with" / "surface"))
  {
    EXPECT_EQ(e.path().extension(), ".obj") << e.path();
    surfaces.push_back(e.path().stem());
  }
  std::sort(frames.begin(), frames.end());
  std::sort(surfaces.begin(), surfaces.end());
  EXPECT_EQ(frames.size(), 5u);
  EXPECT_EQ(surfaces, frames);
  // Each a mesh (the 64 particles' block is one closed surface); the first one's triangles.
  const std::string first = test::readFile(dir.file("with/surface/000000.obj"));
  EXPECT_EQ(first.rfind("# fluid_sim free surface: ", 0), 0u) << first.substr(0, 80);
  EXPECT_NE(first.find("\nv "), std::string::npos);
  EXPECT_NE(first.find("\nf "), std::string::npos);
  EXPECT_NE(r.out.find("surface  5 meshes"), std::string::npos) << r.out;
  // The run itself is the same with and without it: its frames byte for byte.
  for (const std::string& f : frames)
    EXPECT_EQ(test::readFile(dir.file("with/frames/" + f + ".ply")),
              test::readFile(dir.file("plain/frames/" + f + ".ply")))
        << f;
}

TEST(Runner, BadSceneExitsTwoNamingFileAndKey)
{
  test::TempDir dir;
  dir.write("bad.yaml", std::string(kTinyScene) + "solver: {density_eror: 0.001}\n");
  const RunResult r = run(dir, "bad.yaml");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("error: bad.yaml: solver.density_eror: unknown key"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir.path() / "out"));

  dir.write("tiny.yaml", kTinyScene);
  const RunResult unknown_override = run(dir, "tiny.yaml --set solver.omga=0.5");
  EXPECT_EQ(unknown_override.exit_code, 2);
  EXPECT_NE(unknown_override.err.find("solver.omga"), std::string::npos) << unknown_override.err;

  EXPECT_EQ(run(dir, "missing.yaml").exit_code, 2);
  EXPECT_EQ(run(dir, "tiny.yaml --threads 0").exit_code, 2);
}

TEST(Runner, UnstableRunExitsThreeWithSummary)
{
  test::TempDir dir;
  dir.write("tiny.yaml", kTinyScene);
  // A CFL limit no falling particle can keep: unstable within a few steps.
  const RunResult r = run(dir, "tiny.yaml --out result --set stability.max_cfl=0.001");
  EXPECT_EQ(r.exit_code, 3) << r.err;
  EXPECT_NE(r.err.find("unstable"), std::string::npos) << r.err;
  const nlohmann::json summary = readJson(dir.file("result/summary.json"));
  EXPECT_EQ(summary["status"], "unstable");
  EXPECT_NE(summary["reason"].get<std::string>().find("max_cfl"), std::string::npos) << summary["reason"];
  EXPECT_EQ(lineCount(dir.file("result/stats.csv")), summary["steps"].get<std::size_t>() + 1);
}

TEST(Runner, SigintWritesInterruptedSummary)
{
  test::TempDir dir;
  const std::string scene = dir.write("tiny.yaml", kTinyScene);
  const std::string out = dir.file("result");
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0)
  {
    const int sink = open("/dev/null", O_WRONLY);
    dup2(sink, STDOUT_FILENO);
    dup2(sink, STDERR_FILENO);
    execl(FLUID_SIM_RUN, FLUID_SIM_RUN, scene.c_str(), "--out", out.c_str(), "--duration", "1000", "--threads", "1",
          static_cast<char*>(nullptr));
    _exit(127);
  }
  // Wait until it is stepping (the second frame exists), then interrupt. No wall-clock deadline:
  // a loaded machine only makes the wait longer (ctest's timeout bounds the test); a runner that
  // ends on its own before that is a failure of its own.
  int status = 0;
  while (!fs::exists(out + "/frames/000001.ply"))
  {
    ASSERT_EQ(waitpid(pid, &status, WNOHANG), 0) << "the runner ended before its second frame";
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  kill(pid, SIGINT);
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 130);
  const nlohmann::json summary = readJson(out + "/summary.json");
  EXPECT_EQ(summary["status"], "interrupted");
  EXPECT_GT(summary["steps"].get<int>(), 0);
}

/// The lines of a text file, without their newlines.
std::vector<std::string> lines(const std::string& path)
{
  std::vector<std::string> out;
  std::istringstream in(test::readFile(path));
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

/// The comma-separated fields of a CSV line.
std::vector<std::string> fields(const std::string& line)
{
  std::vector<std::string> out;
  std::istringstream in(line);
  for (std::string field; std::getline(in, field, ',');) out.push_back(field);
  return out;
}

const char* const kInstruments = R"yaml(
regions:
  - name: tank_water
    box: {min: [0, 0, 0], max: [0.4, 0.4, 0.5]}
  - name: ball_zone
    sphere: {center: [0.3, 0.3, 0.1], radius: 0.1}
probes:
  - name: deep
    position: [0.15, 0.15, 0.15]
  - name: air
    position: [0.15, 0.15, 0.45]
spill: {below: 0.6}
)yaml";

TEST(Runner, WritesInstrumentFiles)
{
  test::TempDir dir;
  dir.write("tiny.yaml", std::string(kTinyScene) + kInstruments);
  const RunResult r = run(dir, "tiny.yaml --out result --threads 1");
  ASSERT_EQ(r.exit_code, 0) << r.err;

  // One row per region and per probe at each of the five frame times (t = 0, 0.05, ..., 0.2 s).
  const std::vector<std::string> regions = lines(dir.file("result/regions.csv"));
  ASSERT_EQ(regions.size(), 1u + 5u * 2u);
  EXPECT_EQ(regions[0], "t,region,volume_m3,mass_kg,fill_fraction,vx,vy,vz,particles");
  // At t = 0 the tank holds the 64 particles of the 0.2 m cube: 0.008 m^3 of the tank's 0.08.
  const std::vector<std::string> first = fields(regions[1]);
  ASSERT_EQ(first.size(), 9u);
  EXPECT_EQ(first[0], "0");
  EXPECT_EQ(first[1], "tank_water");
  EXPECT_NEAR(std::stod(first[2]), 0.008, 1e-12);
  EXPECT_NEAR(std::stod(first[3]), 8.0, 1e-9);
  EXPECT_NEAR(std::stod(first[4]), 0.1, 1e-9);
  EXPECT_EQ(first[8], "64");
  EXPECT_EQ(fields(regions[2])[1], "ball_zone");
  const std::vector<std::string> last = fields(regions.back());
  EXPECT_NEAR(std::stod(last[0]), 0.2, 1e-9);
  EXPECT_EQ(fields(regions[regions.size() - 2])[8], "64");  // the tank keeps its water

  const std::vector<std::string> probes = lines(dir.file("result/probes.csv"));
  ASSERT_EQ(probes.size(), 1u + 5u * 2u);
  EXPECT_EQ(probes[0], "t,probe,x,y,z,pressure_pa,density,vx,vy,vz,wet");
  // At t = 0 `deep` is the water cube's centre (wet, about rest density; no pressure before the
  // first step), `air` above it; at the end `air` is still dry and reads no pressure.
  const std::vector<std::string> deep = fields(probes[1]), air = fields(probes.back());
  ASSERT_EQ(deep.size(), 11u);
  EXPECT_EQ(deep[1], "deep");
  EXPECT_NEAR(std::stod(deep[4]), 0.15, 1e-12);
  EXPECT_EQ(deep[10], "1");
  EXPECT_GT(std::stod(deep[6]), 900.0);
  EXPECT_EQ(air[1], "air");
  EXPECT_NEAR(std::stod(air[0]), 0.2, 1e-9);
  EXPECT_EQ(air[10], "0");
  EXPECT_EQ(air[5], "0");

  const std::vector<std::string> spill = lines(dir.file("result/spill.csv"));
  ASSERT_EQ(spill.size(), 1u + 5u);
  EXPECT_EQ(spill[0], "t,below_m,particles,volume_m3,mass_kg");
  const nlohmann::json summary = readJson(dir.file("result/summary.json"));
  ASSERT_TRUE(summary.contains("spill"));
  EXPECT_DOUBLE_EQ(summary["spill"]["below_m"].get<double>(), 0.6);
  EXPECT_EQ(summary["spill"]["particles"], 0);  // all inside the tank region
  EXPECT_NE(r.out.find("measured 5 times"), std::string::npos) << r.out;
}

TEST(Runner, InstrumentsSpillOutsideRegionsAndNoFilesWithoutThem)
{
  test::TempDir dir;
  // Only the ball's neighbourhood is a region: the water in the tank's floor layers is spilt.
  dir.write("tiny.yaml", std::string(kTinyScene) +
                             "regions: [{name: ball_zone, sphere: {center: [0.3, 0.3, 0.1], radius: 0.1}}]\n"
                             "spill: {below: 0.6}\n");
  RunResult r = run(dir, "tiny.yaml --out spilt --threads 1 --duration 0.02 --set output.frame_interval=0");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // Without frames: measured at the start and after the last step.
  EXPECT_EQ(lines(dir.file("spilt/regions.csv")).size(), 1u + 2u);
  EXPECT_FALSE(fs::exists(dir.path() / "spilt" / "probes.csv"));
  const nlohmann::json summary = readJson(dir.file("spilt/summary.json"));
  const std::size_t in_zone = std::stoul(fields(lines(dir.file("spilt/regions.csv")).back())[8]);
  EXPECT_EQ(summary["spill"]["particles"].get<std::size_t>() + in_zone, 64u);
  EXPECT_GT(summary["spill"]["particles"].get<std::size_t>(), 0u);

  dir.write("plain.yaml", kTinyScene);
  r = run(dir, "plain.yaml --out plain --threads 1 --duration 0.02 --set output.frame_interval=0");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* file : {"regions.csv", "probes.csv", "spill.csv"})
    EXPECT_FALSE(fs::exists(dir.path() / "plain" / file)) << file;
  EXPECT_FALSE(readJson(dir.file("plain/summary.json")).contains("spill"));
}

TEST(Runner, AReusedOutputDirectoryHoldsOnlyTheNewRunsFiles)
{
  // A run with instruments, sinks, emitters and surfaces, then a plain run into the same folder:
  // a script reading regions.csv beside the new summary.json must not read the first run's.
  test::TempDir dir;
  dir.write("busy.yaml", std::string(kTinyScene) +
                             "regions: [{name: zone, sphere: {center: [0.3, 0.3, 0.1], radius: 0.1}}]\n"
                             "probes: [{name: p, position: [0.15, 0.15, 0.1]}]\n"
                             "spill: {below: 0.6}\n"
                             "sinks: [{name: drain, sphere: {center: [0.3, 0.1, 0.05], radius: 0.04}}]\n"
                             "emitters: [{name: tap, circle: {radius: 0.02}, pose: {xyz: [0.2, 0.2, 0.4]}, "
                             "direction: [0, 0, -1], speed: 0.5}]\n");
  RunResult r = run(dir, "busy.yaml --out out --threads 1 --duration 0.1 --surface");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* file : {"regions.csv", "probes.csv", "spill.csv", "sinks.csv", "emitters.csv", "surface/000002.obj"})
    ASSERT_TRUE(fs::exists(dir.path() / "out" / file)) << file;
  dir.write("plain.yaml", kTinyScene);
  r = run(dir, "plain.yaml --out out --threads 1 --duration 0.02 --set output.frame_interval=0");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* file : {"regions.csv", "probes.csv", "spill.csv", "sinks.csv", "emitters.csv", "frames/000001.ply",
                           "surface/000000.obj", "surface/000002.obj"})
    EXPECT_FALSE(fs::exists(dir.path() / "out" / file)) << file;
  EXPECT_TRUE(fs::exists(dir.path() / "out" / "summary.json"));
  EXPECT_TRUE(fs::exists(dir.path() / "out" / "stats.csv"));
  // A scene that cannot be built leaves the earlier run's output as it was.
  dir.write("broken.yaml", std::string(kTinyScene) + "spacing_typo: 1\n");
  r = run(dir, "broken.yaml --out out --threads 1");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_TRUE(fs::exists(dir.path() / "out" / "summary.json"));
}

TEST(Runner, BadOptionValuesExitTwoNamingTheOption)
{
  test::TempDir dir;
  dir.write("tiny.yaml", kTinyScene);
  for (const char* args : {"--duration nan", "--duration -1", "--duration inf", "--threads 0", "--threads 5000"})
  {
    const RunResult r = run(dir, std::string("tiny.yaml --out o ") + args);
    EXPECT_EQ(r.exit_code, 2) << args;
    const std::string option = std::string(args).substr(0, std::string(args).find(' '));
    EXPECT_NE(r.err.find(option + ":"), std::string::npos) << args << ": " << r.err;
    EXPECT_EQ(r.err.find("179769"), std::string::npos) << r.err;  // no DBL_MAX spelled out
    EXPECT_FALSE(fs::exists(dir.path() / "o")) << args;
  }
}

TEST(Runner, RegionOfAnUnknownBodyExitsTwoNamingIt)
{
  test::TempDir dir;
  dir.write("tiny.yaml", std::string(kTinyScene) + "regions: [{name: cup, body: mug}]\n");
  const RunResult r = run(dir, "tiny.yaml --out result");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("error: tiny.yaml: regions[0].body: no boundary body named 'mug' (bodies: tank, ball)"),
            std::string::npos)
      << r.err;
}

TEST(Runner, WritesEmittersCsvAndSummaryAndRefusesATfFrame)
{
  // A tap over the tiny tank: at 5 cm spacing a 1 cm opening is its centre point; at 0.5 m/s for
  // 0.1 s the stream moves one spacing: one layer, one particle.
  test::TempDir dir;
  dir.write("tiny.yaml", std::string(kTinyScene) +
                             "emitters:\n"
                             "  - {name: tap, circle: {radius: 0.01}, pose: {xyz: [0.2, 0.2, 0.45]}, "
                             "direction: [0, 0, -1], speed: 0.5, duration: 0.1}\n");
  const RunResult r = run(dir, "tiny.yaml --out result");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string csv = test::readFile((dir.path() / "result" / "emitters.csv").string());
  EXPECT_EQ(csv.substr(0, csv.find('\n')), "t,emitter,particles,volume_m3,mass_kg,blocked");
  EXPECT_NE(csv.find(",tap,1,"), std::string::npos) << csv;
  const nlohmann::json j = readJson((dir.path() / "result" / "summary.json").string());
  EXPECT_EQ(j["emitters"]["tap"]["particles"], 1);
  EXPECT_NEAR(j["emitters"]["tap"]["volume_m3"].get<double>(), 0.05 * 0.05 * 0.05, 1e-12);
  EXPECT_NEAR(j["emitters"]["tap"]["flow_rate_m3_s"].get<double>(), 0.05 * 0.05 * 0.5, 1e-12);
  EXPECT_NE(r.out.find("emitter  tap: released 1 particles"), std::string::npos) << r.out;
  // A tiny scene without emitters writes no emitters.csv.
  test::TempDir plain;
  plain.write("tiny.yaml", kTinyScene);
  ASSERT_EQ(run(plain, "tiny.yaml --out result").exit_code, 0);
  EXPECT_FALSE(fs::exists(plain.path() / "result" / "emitters.csv"));
  // A nozzle fixed in a tf frame is the node's.
  test::TempDir tf;
  tf.write("tiny.yaml",
           std::string(kTinyScene) + "emitters: [{name: hose, circle: {radius: 0.01}, speed: 1, frame: gripper}]\n");
  const RunResult refused = run(tf, "tiny.yaml --out result");
  EXPECT_EQ(refused.exit_code, 2);
  EXPECT_NE(refused.err.find("emitters[0].frame: 'gripper' is a tf frame"), std::string::npos) << refused.err;
}

// The tiny tank with a free box of density 500 kg/m^3 above the water (format only: the dynamics
// are the core's and tested there).
const char* const kFreeBox = R"yaml(
  - name: raft
    box: {min: [0.1, 0.1, 0.3], max: [0.2, 0.2, 0.4]}
    dynamic: {density: 500}
)yaml";

TEST(Runner, WritesFreeBodiesCsvAndSummary)
{
  test::TempDir dir;
  // No free body: neither bodies.csv nor free_bodies.
  dir.write("plain.yaml", kTinyScene);
  RunResult r = run(dir, "plain.yaml --out plain --threads 1 --duration 0.01");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_FALSE(fs::exists(dir.path() / "plain" / "bodies.csv"));
  EXPECT_FALSE(readJson(dir.file("plain/summary.json")).contains("free_bodies"));

  // kTinyScene's boundaries list ends just before `output`: the raft goes after the ball.
  std::string scene = kTinyScene;
  scene.insert(scene.find("output:"), std::string(kFreeBox).substr(1));
  const std::string path = dir.write("raft.yaml", scene);
  {
    Simulation sim(io::loadScene(path));
    if (!sim.body(sim.bodyIndex("raft")).free)
      GTEST_SKIP() << "the core does not mark free bodies yet (BodyInfo::free); bodies.csv is not written";
  }
  // Frames every 0.01 s for 0.02 s (10 steps of 2 ms): measured at t = 0, 0.01 and 0.02 s.
  r = run(dir, "raft.yaml --out raft --threads 1 --duration 0.02 --set output.frame_interval=0.01");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::vector<std::string> rows = lines(dir.file("raft/bodies.csv"));
  ASSERT_EQ(rows.size(), 1u + 3u);  // the raft only: the tank and the ball are not free
  EXPECT_EQ(rows[0], "t,body,x,y,z,qx,qy,qz,qw,vx,vy,vz,wx,wy,wz,fx,fy,fz,tx,ty,tz");
  for (std::size_t i = 1; i < rows.size(); ++i)
  {
    const std::vector<std::string> f = fields(rows[i]);
    ASSERT_EQ(f.size(), 21u) << rows[i];
    EXPECT_NEAR(std::stod(f[0]), 0.01 * double(i - 1), 1e-9) << rows[i];
    EXPECT_EQ(f[1], "raft");
    for (std::size_t k = 2; k < f.size(); ++k) EXPECT_NO_THROW((void)std::stod(f[k])) << rows[i];
  }
  const nlohmann::json summary = readJson(dir.file("raft/summary.json"));
  ASSERT_TRUE(summary.contains("free_bodies"));
  ASSERT_EQ(summary["free_bodies"].size(), 1u);
  const nlohmann::json& raft = summary["free_bodies"]["raft"];
  EXPECT_EQ(raft["center_of_mass"].size(), 3u);
  EXPECT_EQ(raft["orientation"].size(), 4u);
  EXPECT_EQ(raft["linear_velocity"].size(), 3u);
  EXPECT_EQ(raft["angular_velocity"].size(), 3u);
  EXPECT_TRUE(raft["mass"].is_number());
}

}  // namespace
}  // namespace fluid_sim
