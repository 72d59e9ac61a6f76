// Starting a run from a saved state (scene key fluid[i].particles: {file}): the key, its errors,
// and whether a run resumed from a frame goes on as the run that wrote the frame.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "fluid_sim/core/simulation.h"
#include "fluid_sim/io/ply_reader.h"
#include "fluid_sim/io/ply_writer.h"
#include "fluid_sim/io/scene_loader.h"
#include "fluid_sim/io/simulation_output.h"
#include "temp_dir.h"

namespace fluid_sim
{
namespace
{
namespace fs = std::filesystem;

// A dam break in a closed tank: a 6 x 10 x 10 column (600 particles) collapses; after 0.2 s its
// front runs along the floor at about 1 m/s and hits the far wall. No moving body: the bodies
// start from the scene's definitions again on a resume.
const std::string kTank = R"yaml(
spacing: 0.02
domain: {min: [-0.1, -0.1, -0.1], max: [0.5, 0.3, 0.5]}
time_step: {fixed: 0.002}
boundaries:
  - name: tank
    box: {min: [0, 0, 0], max: [0.3, 0.2, 0.3]}
    inside: true
  - name: post
    sphere: {center: [0.22, 0.1, 0.05], radius: 0.04}
)yaml";
const std::string kColumn = "fluid:\n  - box: {min: [0, 0, 0], max: [0.12, 0.2, 0.2]}\n";

/// A lattice of n^3 points `gap` (m) apart from `origin`, with velocity `v` (m/s).
io::PlyFrame lattice(int n, double gap, const Vec3d& origin, const Vec3d& v = Vec3d::Zero())
{
  io::PlyFrame f;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
      {
        f.positions.push_back(origin + gap * Vec3d(i, j, k));
        f.velocities.push_back(v);
      }
  return f;
}

/// Writes `f` as the runner writes frames (float32, zero pressure, rest density).
void writeFrame(const std::string& path, const io::PlyFrame& f)
{
  std::vector<Vec3> x, v;
  for (const Vec3d& p : f.positions) x.push_back(p.cast<Real>());
  for (const Vec3d& u : f.velocities) v.push_back(u.cast<Real>());
  io::writePly(path, x, v, std::vector<Real>(x.size(), 0), std::vector<Real>(x.size(), 1000));
}

/// The message of the SceneError parsing `yaml` as dir/scene.yaml throws ("" if none).
std::string errorOf(const test::TempDir& dir, const std::string& yaml)
{
  try
  {
    io::parseScene(yaml, dir.file("scene.yaml"));
  }
  catch (const io::SceneError& e)
  {
    return e.what();
  }
  return "";
}

void expectError(const test::TempDir& dir, const std::string& yaml, const std::string& key, const std::string& detail)
{
  const std::string what = errorOf(dir, yaml);
  EXPECT_NE(what.find("scene.yaml: " + key + ": "), std::string::npos) << what;
  EXPECT_NE(what.find(detail), std::string::npos) << "expected '" << detail << "' in: " << what;
}

TEST(ParticlesKey, ReadsTheFrameRelativeToTheSceneFileBesideBoxBlocks)
{
  test::TempDir dir;
  fs::create_directories(dir.path() / "frames");
  fs::create_directories(dir.path() / "scenes");
  const io::PlyFrame f = lattice(3, 0.02, Vec3d(0.03, 0.03, 0.01), Vec3d(0.5, 0, -0.25));
  writeFrame(dir.file("frames/000300.ply"), f);
  const SceneConfig s = io::parseScene(kTank +
                                           "fluid:\n"
                                           "  - box: {min: [0.2, 0, 0.15], max: [0.3, 0.1, 0.25]}\n"
                                           "  - particles: {file: ../frames/000300.ply}\n",
                                       dir.file("scenes/resume.yaml"));
  ASSERT_EQ(s.fluid.size(), 2u);
  EXPECT_FALSE(s.fluid[0].particles);
  ASSERT_TRUE(s.fluid[1].particles);
  EXPECT_EQ(s.fluid[1].particles->positions.size(), 27u);
  EXPECT_TRUE(s.warnings.empty()) << s.warnings.front();  // its spacing is the scene's

  // The lattice block first, then the particles in the file's order, with their velocities and
  // the lattice particles' mass.
  Simulation sim(s);
  ASSERT_EQ(sim.numFluidParticles(), 125u + 27u);
  EXPECT_EQ(sim.removedAtStart(), 0u);
  EXPECT_DOUBLE_EQ(sim.particleMass(), Real(1000.0 * 0.02 * 0.02 * 0.02));
  for (std::size_t i = 0; i < 27; ++i)
  {
    // As the file holds them: float32.
    EXPECT_EQ(sim.positions()[125 + i], f.positions[i].cast<float>().cast<Real>()) << i;
    EXPECT_EQ(sim.velocities()[125 + i], f.velocities[i].cast<float>().cast<Real>()) << i;
  }
  EXPECT_EQ(sim.time(), 0.0);  // a resumed run starts at t = 0
}

TEST(ParticlesKey, KeyErrorsNameTheKeyAndLine)
{
  test::TempDir dir;
  writeFrame(dir.file("f.ply"), lattice(2, 0.02, Vec3d(0.05, 0.05, 0.05)));
  expectError(dir, kTank + "fluid:\n  - particles: {fille: f.ply}\n", "fluid[0].particles.fille",
              "unknown key (did you mean 'file'?) (line 12)");
  expectError(dir, kTank + "fluid:\n  - particles: {}\n", "fluid[0].particles.file", "missing");
  expectError(dir, kTank + "fluid:\n  - particles: {file: [f.ply]}\n", "fluid[0].particles.file", "expected a string");
  expectError(dir, kTank + "fluid:\n  - particles: {file: f.ply}\n    box: {min: [0, 0, 0], max: [0.1, 0.1, 0.1]}\n",
              "fluid[0]", "give either box or particles, not both (line 12)");
  expectError(dir, kTank + "fluid:\n  - velocity: [1, 0, 0]\n", "fluid[0]", "needs box or particles (line 12)");
  expectError(dir, kTank + "fluid:\n  - particles: {file: f.ply}\n    velocity: [1, 0, 0]\n", "fluid[0].velocity",
              "only with box (particles carry their own velocities) (line 13)");
  expectError(dir, kTank + "fluid:\n  - particles: {file: f.ply}\n    velocty: [1, 0, 0]\n", "fluid[0].velocty",
              "did you mean 'velocity'?");
}

TEST(ParticlesKey, FileErrorsNameTheKeyTheFileAndTheFault)
{
  test::TempDir dir;
  fs::create_directories(dir.path() / "frames");
  const std::string resolved = dir.file("frames/none.ply");
  expectError(dir, kTank + "fluid:\n  - particles: {file: frames/none.ply}\n", "fluid[0].particles.file",
              "frames/none.ply (= " + resolved + "): no such file (line 12)");

  writeFrame(dir.file("frames/whole.ply"), lattice(2, 0.02, Vec3d(0.05, 0.05, 0.05)));
  const std::string whole = test::readFile(dir.file("frames/whole.ply"));
  dir.write("frames/cut.ply", whole.substr(0, whole.size() - 4));
  expectError(dir, kTank + "fluid:\n  - particles: {file: frames/cut.ply}\n", "fluid[0].particles.file",
              "frames/cut.ply (= " + dir.file("frames/cut.ply") + "): truncated: the header announces 8 vertices");

  // A frame with no particle at all (every one had left the domain).
  writeFrame(dir.file("frames/empty.ply"), io::PlyFrame());
  expectError(dir, kTank + "fluid:\n  - particles: {file: frames/empty.ply}\n", "fluid[0].particles",
              "holds no particle");
}

TEST(ParticlesKey, ParticlesInSolidsOutsideContainersOrOutsideTheDomainAreDroppedAndCounted)
{
  test::TempDir dir;
  io::PlyFrame f = lattice(2, 0.02, Vec3d(0.05, 0.05, 0.05));
  f.positions.push_back(Vec3d(0.22, 0.1, 0.05));  // in the post
  f.positions.push_back(Vec3d(0.35, 0.1, 0.1));   // outside the tank, inside the domain
  f.positions.push_back(Vec3d(0.1, 0.1, 0.55));   // outside the tank and the domain
  f.velocities.resize(f.positions.size(), Vec3d::Zero());
  writeFrame(dir.file("f.ply"), f);
  const std::string fluid = "fluid:\n  - particles: {file: f.ply}\n";
  Simulation sim(io::parseScene(kTank + fluid, dir.file("scene.yaml")));
  EXPECT_EQ(sim.numFluidParticles(), 8u);
  EXPECT_EQ(sim.removedAtStart(), 3u);

  // Without bodies only the domain applies, with the step's own test (its bounds belong to it).
  const std::string open = "spacing: 0.02\ndomain: {min: [0, 0, 0], max: [0.5, 0.5, 0.5]}\n";
  Simulation free(io::parseScene(open + fluid, dir.file("open.yaml")));
  EXPECT_EQ(free.numFluidParticles(), 10u);
  EXPECT_EQ(free.removedAtStart(), 1u);
}

TEST(ParticlesKey, AFrameSavedAtAnotherSpacingIsWarnedAbout)
{
  test::TempDir dir;
  writeFrame(dir.file("coarse.ply"), lattice(4, 0.05, Vec3d(0.03, 0.03, 0.03)));
  writeFrame(dir.file("fine.ply"), lattice(8, 0.01, Vec3d(0.03, 0.03, 0.03)));
  writeFrame(dir.file("same.ply"), lattice(5, 0.02, Vec3d(0.03, 0.03, 0.03)));
  const auto warnings = [&](const std::string& file) {
    return io::parseScene(kTank + "fluid:\n  - particles: {file: " + file + "}\n", dir.file("scene.yaml")).warnings;
  };
  const std::vector<std::string> coarse = warnings("coarse.ply");
  ASSERT_EQ(coarse.size(), 1u);
  EXPECT_NE(coarse[0].find("fluid[0].particles (coarse.ply): the particles lie more than 0.04 m from their nearest "
                           "neighbours (median), the scene's spacing is 0.02 m"),
            std::string::npos)
      << coarse[0];
  const std::vector<std::string> fine = warnings("fine.ply");
  ASSERT_EQ(fine.size(), 1u);
  EXPECT_NE(fine[0].find("the particles lie about 0.01 m from their nearest neighbours"), std::string::npos) << fine[0];
  EXPECT_TRUE(warnings("same.ply").empty());
  // 10 % closer than the scene's spacing: not obvious from the nearest distances, but 1.37 times
  // rest density, which blows up in the first step (a frame of 3 cm started at 3.5 cm did).
  writeFrame(dir.file("close.ply"), lattice(7, 0.018, Vec3d(0.03, 0.03, 0.03)));
  const std::vector<std::string> close = warnings("close.ply");
  ASSERT_EQ(close.size(), 1u);
  EXPECT_NE(close[0].find("the densest particles sit at 1.37"), std::string::npos) << close[0];
  EXPECT_NE(close[0].find("as if saved at a spacing of about 0.0179"), std::string::npos) << close[0];
  writeFrame(dir.file("near.ply"), lattice(7, 0.0196, Vec3d(0.03, 0.03, 0.03)));  // 2 % off: 1.06
  EXPECT_TRUE(warnings("near.ply").empty());
  // 1.3 spacings apart (a 2 cm frame started at 1.5 cm): the nearest distances pass, the densest
  // particle reads (1/1.3)^3 = 0.46 of rest density: 46 % of the water's mass.
  writeFrame(dir.file("sparse.ply"), lattice(7, 0.026, Vec3d(0.03, 0.03, 0.03)));
  const std::vector<std::string> sparse = warnings("sparse.ply");
  ASSERT_EQ(sparse.size(), 1u);
  EXPECT_NE(sparse[0].find("the densest particles sit at only 0.4"), std::string::npos) << sparse[0];
  EXPECT_NE(sparse[0].find("as if saved at a spacing of about 0.02"), std::string::npos) << sparse[0];
  writeFrame(dir.file("loose.ply"), lattice(7, 0.021, Vec3d(0.03, 0.03, 0.03)));  // 5 % apart: 0.86
  EXPECT_TRUE(warnings("loose.ply").empty());
}

/// Differences between two runs' particles: position (m) and velocity (m/s), largest and rms.
struct Difference
{
  double x = 0.0, v = 0.0;          // largest
  double x_rms = 0.0, v_rms = 0.0;  // root mean square
};

/// Particle by particle, index by index: for states that should be identical, order included.
Difference differenceByIndex(const Simulation& a, const Simulation& b)
{
  Difference d;
  EXPECT_EQ(a.numFluidParticles(), b.numFluidParticles());
  const std::size_t n = std::min(a.numFluidParticles(), b.numFluidParticles());
  for (std::size_t i = 0; i < n; ++i)
  {
    const double dx = (a.positions()[i] - b.positions()[i]).norm(), dv = (a.velocities()[i] - b.velocities()[i]).norm();
    d.x = std::max(d.x, dx);
    d.v = std::max(d.v, dv);
    d.x_rms += dx * dx / n;
    d.v_rms += dv * dv / n;
  }
  d.x_rms = std::sqrt(d.x_rms);
  d.v_rms = std::sqrt(d.v_rms);
  return d;
}

/// Each particle of `a` against the nearest particle of `b`: for states that differ a little, in
/// which the step's sort by grid cell has ordered a few particles differently. Meaningful while
/// the differences stay well below the spacing (then the nearest is the same particle).
Difference differenceByNearest(const Simulation& a, const Simulation& b)
{
  Difference d;
  const std::size_t n = a.numFluidParticles();
  for (std::size_t i = 0; i < n; ++i)
  {
    std::size_t nearest = 0;
    double best = std::numeric_limits<double>::infinity();  // m
    for (std::size_t j = 0; j < b.numFluidParticles(); ++j)
    {
      const double r = (a.positions()[i] - b.positions()[j]).norm();
      if (r < best)
      {
        best = r;
        nearest = j;
      }
    }
    const double dv = (a.velocities()[i] - b.velocities()[nearest]).norm();
    d.x = std::max(d.x, best);
    d.v = std::max(d.v, dv);
    d.x_rms += best * best / n;
    d.v_rms += dv * dv / n;
  }
  d.x_rms = std::sqrt(d.x_rms);
  d.v_rms = std::sqrt(d.v_rms);
  return d;
}

/// The dam break (with the scene keys `solver`) run for `k` steps, and the run started from the
/// frame written at that point.
struct Resumed
{
  test::TempDir dir;
  std::unique_ptr<Simulation> uninterrupted;
  std::unique_ptr<Simulation> resumed;
  std::vector<Vec3d> frame;  // m, the positions the frame holds
};

std::unique_ptr<Resumed> resumeAfter(const std::string& solver, int k, const std::string& time_step = "")
{
  auto r = std::make_unique<Resumed>();
  std::string tank = kTank;
  if (!time_step.empty()) tank.replace(tank.find("time_step: {fixed: 0.002}"), 25, time_step);
  r->uninterrupted = std::make_unique<Simulation>(io::parseScene(tank + solver + kColumn, r->dir.file("tank.yaml")));
  for (int s = 0; s < k; ++s) EXPECT_FALSE(r->uninterrupted->step().unstable);
  io::writePly(r->dir.file("frame.ply"), *r->uninterrupted);  // as the runner writes its frames
  r->frame = io::readPlyFrame(r->dir.file("frame.ply")).positions;
  r->resumed = std::make_unique<Simulation>(
      io::parseScene(tank + solver + "fluid:\n  - particles: {file: frame.ply}\n", r->dir.file("resume.yaml")));
  return r;
}

/// Whether Real is float: then a frame (float32) holds the state exactly.
constexpr bool kFloatBuild = std::is_same<Real, float>::value;

TEST(Resume, FromAFrameEqualsTheUninterruptedRun)
{
  // Without warm start a step depends on the particles' positions, velocities and order, the
  // time step and the time (read only by moving bodies; there are none). The frame holds the
  // first three, and the time step follows from them: the fixed one, or an adaptive one from the
  // largest speed. The order matters: the step sorts the particles by grid cell keeping their
  // order within a cell and sums over neighbours in that order; a fill that reversed the file's
  // order parted the runs by 2e-6 m/s after one step (measured).
  // A float build's frame holds the state exactly: the runs stay equal bit for bit. A double
  // build's frame rounds it to float32 (4.5e-9 m and 1.8e-8 m/s rms), and the runs stay apart by
  // about that: measured 7.6e-8 m at most and 9.5e-7 m/s rms after 25 steps.
  // Resumed 0.1 s into the flow, when no particle has crossed a wall's surface (see below); the
  // adaptive step takes about 0.005 s until the front is fast, so 20 steps reach t = 0.1 s too.
  for (const auto& [time_step, k] : std::vector<std::pair<std::string, int>>{{"", 50}, {"time_step: {cfl: 0.4}", 20}})
  {
    SCOPED_TRACE(time_step.empty() ? "fixed time step" : time_step);
    const auto r = resumeAfter("", k, time_step);
    EXPECT_NEAR(r->uninterrupted->time(), 0.1, 0.02);  // s
    Simulation& a = *r->uninterrupted;
    Simulation& b = *r->resumed;
    ASSERT_EQ(b.removedAtStart(), 0u);
    Difference d = differenceByIndex(a, b);
    ASSERT_LE(d.x, kFloatBuild ? 0.0 : 1e-8);  // m
    ASSERT_LE(d.v, kFloatBuild ? 0.0 : 1e-7);  // m/s
    const double t0 = a.time();                // s
    for (int s = 1; s <= 25; ++s)
    {
      const StepReport ra = a.step(), rb = b.step();
      // The resume is in the middle of the flow (m/s), and the adaptive step is set by the speed,
      // below its maximum (s).
      if (s == 1) EXPECT_GT(ra.max_speed, 1.0);
      if (!time_step.empty()) EXPECT_LT(ra.dt, 0.005) << "step " << s;
      if (kFloatBuild)
      {
        EXPECT_EQ(ra.dt, rb.dt) << "step " << s;
        EXPECT_EQ(ra.divergence_iterations, rb.divergence_iterations) << "step " << s;
        EXPECT_EQ(ra.density_iterations, rb.density_iterations) << "step " << s;
        d = differenceByIndex(a, b);
        EXPECT_EQ(d.x, 0.0) << "step " << s;
        EXPECT_EQ(d.v, 0.0) << "step " << s;
      }
      else
      {
        // s: an adaptive step follows the largest speed, which differs by about 1e-6 of it.
        EXPECT_NEAR(ra.dt, rb.dt, 1e-5 * ra.dt) << "step " << s;
        d = differenceByNearest(a, b);
        EXPECT_LT(d.x, 1e-6) << "step " << s;      // m
        EXPECT_LT(d.v_rms, 1e-5) << "step " << s;  // m/s
      }
    }
    // Counted from 0: the frame stores no time.
    EXPECT_NEAR(b.time(), a.time() - t0, (kFloatBuild ? 1e-12 : 1e-5) * (a.time() - t0));
  }
}

TEST(Resume, PreviousStepPressuresAreNotInTheFrameSoTheRunsPartSlightly)
{
  // With solver.warm_start each solve starts from the previous step's pressures. The frame holds
  // only their sum (property pressure), not each solve's, so the resumed run starts its first
  // solves from zero and both stop at the tolerance with other pressures: measured, the first
  // step's velocities differ by 0.021 m/s rms (0.057 largest) at speeds up to 1.7 m/s, and after
  // 25 steps (0.05 s) the positions by 0.43 mm rms (1.9 mm largest; spacing 20 mm) and the
  // velocities by 0.028 m/s rms (0.033 at most over the 25 steps); in a double build 0.031 m/s
  // rms after the first step, 0.50 mm rms after 25, and 0.052 m/s rms at most. The sort then
  // orders a few particles differently, so particles are compared with the nearest of the other run.
  const auto r = resumeAfter("solver: {warm_start: true}\n", 50);
  Simulation& a = *r->uninterrupted;
  Simulation& b = *r->resumed;
  ASSERT_EQ(b.removedAtStart(), 0u);
  ASSERT_LE(differenceByIndex(a, b).v, kFloatBuild ? 0.0 : 1e-7);  // m/s
  for (int s = 1; s <= 25; ++s)
  {
    a.step();
    b.step();
    const Difference d = differenceByNearest(a, b);
    // The first step differs by far more than rounding (m/s); the runs stay within about twice
    // what was measured: positions 0.05 spacing rms and 0.25 spacing at most (m), velocities
    // 0.1 m/s rms (6 % of the flow's speed).
    if (s == 1) EXPECT_GT(d.v_rms, 1e-3) << "the first step after the resume differs";
    EXPECT_LT(d.x_rms, 0.05 * 0.02) << "step " << s;
    EXPECT_LT(d.x, 0.25 * 0.02) << "step " << s;
    EXPECT_LT(d.v_rms, 0.1) << "step " << s;
  }
}

TEST(Resume, ParticlesPastAWallsSurfaceAreDroppedLikeLatticePoints)
{
  // The fill removes what lies in a solid or outside a container, as it does for the lattice, so
  // that a body added to the saved scene clears the water it displaces. Mid-flow, water pressed
  // against a wall lies up to about 0.3 spacing past the wall's geometric surface (the boundary
  // particles are half a spacing beyond it): at t = 0.2 s here a few particles do, and a resume
  // from that frame goes on without them.
  const auto r = resumeAfter("", 100);
  const Simulation& a = *r->uninterrupted;
  const Simulation& b = *r->resumed;
  std::vector<Vec3d> kept;
  for (const Vec3d& x : r->frame)
  {
    const bool outside_tank = (x.array() < 0.0).any() || x.x() > 0.3 || x.y() > 0.2 || x.z() > 0.3;
    const bool in_post = (x - Vec3d(0.22, 0.1, 0.05)).norm() < 0.04;
    if (!outside_tank && !in_post) kept.push_back(x);
  }
  ASSERT_EQ(r->frame.size(), a.numFluidParticles());
  EXPECT_GT(r->frame.size() - kept.size(), 0u);  // what makes this frame the case in point
  EXPECT_EQ(b.removedAtStart(), r->frame.size() - kept.size());
  ASSERT_EQ(b.numFluidParticles(), kept.size());
  for (std::size_t i = 0; i < kept.size(); ++i) EXPECT_EQ(b.positions()[i], kept[i].cast<Real>()) << i;
}

#ifdef FLUID_SIM_RUN
TEST(ParticlesKey, TheRunnerStartsFromItsOwnFrame)
{
  test::TempDir dir;
  dir.write("tank.yaml", kTank + kColumn + "output: {frame_interval: 0.01}\n");
  const test::RunResult first = test::runRunner(dir, "tank.yaml --duration 0.05 --threads 1");
  ASSERT_EQ(first.exit_code, 0) << first.err;
  const std::size_t saved = io::readPlyFrame(dir.file("out/tank/frames/000005.ply")).positions.size();
  dir.write("resume.yaml", kTank + "fluid:\n  - particles: {file: out/tank/frames/000005.ply}\n");
  const test::RunResult second = test::runRunner(dir, "resume.yaml --duration 0.01 --threads 1");
  ASSERT_EQ(second.exit_code, 0) << second.err;
  EXPECT_EQ(second.err.find("warning"), std::string::npos) << second.err;
  const nlohmann::json summary = nlohmann::json::parse(test::readFile(dir.file("out/resume/summary.json")));
  EXPECT_EQ(summary["fluid_particles"]["initial"].get<std::size_t>(), saved);
  EXPECT_EQ(summary["fluid_particles"]["removed_at_start"], 0);
  EXPECT_EQ(summary["steps"], 5);
}
#endif

}  // namespace
}  // namespace fluid_sim
