#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "fluid_sim/io/bodies_writer.h"
#include "fluid_sim/io/ply_writer.h"
#include "fluid_sim/io/run_summary.h"
#include "fluid_sim/io/stats_writer.h"
#include "temp_dir.h"

namespace fluid_sim
{
namespace
{
const std::string kPlyHeaderProperties =
    "element vertex 3\n"
    "property float x\n"
    "property float y\n"
    "property float z\n"
    "property float vx\n"
    "property float vy\n"
    "property float vz\n"
    "property float pressure\n"
    "property float density\n"
    "end_header\n";

float readFloatLe(const std::string& data, std::size_t offset)
{
  std::uint32_t bits = 0;
  for (int k = 0; k < 4; ++k) bits |= std::uint32_t(static_cast<unsigned char>(data[offset + k])) << (8 * k);
  float f;
  std::memcpy(&f, &bits, sizeof f);
  return f;
}

TEST(PlyWriter, HeaderSizeAndValuesRoundTrip)
{
  test::TempDir dir;
  const std::vector<Vec3> x = {Vec3(0.1f, 0.2f, 0.3f), Vec3(-1, 2, 3), Vec3(4, 5, 6.5f)};
  const std::vector<Vec3> v = {Vec3(1, 0, 0), Vec3(0, -2, 0), Vec3(0.25f, 0.5f, 0.75f)};
  const std::vector<Real> p = {0, 981.5f, 1.0e5f};
  const std::vector<Real> rho = {1000, 1001.25f, 999};
  const std::string path = dir.file(io::frameFileName(7));
  io::writePly(path, x, v, p, rho);

  EXPECT_EQ(io::frameFileName(7), "000007.ply");
  EXPECT_FALSE(std::filesystem::exists(path + ".tmp"));
  const std::string data = test::readFile(path);
  EXPECT_EQ(data.rfind("ply\nformat binary_little_endian 1.0\n", 0), 0u);
  const std::size_t header_end = data.find("end_header\n") + std::string("end_header\n").size();
  ASSERT_NE(header_end, std::string::npos);
  const std::string header = data.substr(0, header_end);
  EXPECT_NE(header.find(kPlyHeaderProperties), std::string::npos) << header;
  ASSERT_EQ(data.size(), header_end + 3 * 8 * sizeof(float));

  for (std::size_t i = 0; i < 3; ++i)
  {
    const std::size_t row = header_end + i * 8 * sizeof(float);
    for (int k = 0; k < 3; ++k)
    {
      EXPECT_EQ(readFloatLe(data, row + 4 * k), x[i][k]);
      EXPECT_EQ(readFloatLe(data, row + 4 * (3 + k)), v[i][k]);
    }
    EXPECT_EQ(readFloatLe(data, row + 24), p[i]);
    EXPECT_EQ(readFloatLe(data, row + 28), rho[i]);
  }
}

TEST(PlyWriter, EmptyFrameAndMismatchedArrays)
{
  test::TempDir dir;
  io::writePly(dir.file("empty.ply"), {}, {}, {}, {});
  EXPECT_NE(test::readFile(dir.file("empty.ply")).find("element vertex 0\n"), std::string::npos);
  EXPECT_THROW(io::writePly(dir.file("bad.ply"), {Vec3::Zero()}, {}, {}, {}), std::invalid_argument);
  EXPECT_THROW(io::writePly(dir.file("no/such/dir/x.ply"), {}, {}, {}, {}), std::runtime_error);
}

TEST(StatsCsvWriter, HeaderAndRows)
{
  test::TempDir dir;
  const std::string path = dir.file("stats.csv");
  {
    io::StatsCsvWriter csv(path);
    StepReport r;
    r.time = 0.001;
    r.dt = 0.001;
    r.density_iterations = 4;
    r.fluid_particles = 1234;
    r.kinetic_energy = 0.25;
    r.boundary_pressure_work = -0.125;
    r.density_residual_max = {0.5f, 0.75f, 0.125f};
    r.wall_guarded = 3;
    r.wall_guard_max_shift = 0.0025;
    csv.write(1, r, 2.5);
    r.time = 0.002;
    r.density_residual_max.clear();
    r.wall_guarded = 0;
    r.wall_guard_max_shift = 0.0;
    csv.write(2, r, 2.0);
    csv.flush();
  }
  std::istringstream lines(test::readFile(path));
  std::string header, row1, row2, extra;
  std::getline(lines, header);
  std::getline(lines, row1);
  std::getline(lines, row2);
  EXPECT_FALSE(std::getline(lines, extra));
  EXPECT_EQ(header.rfind("step,t,dt,divergence_iterations,density_iterations,density_error,divergence_error,"
                         "max_speed,fluid_particles,removed,wall_ms",
                         0),
            0u)
      << header;
  EXPECT_EQ(row1.rfind("1,0.001,0.001,0,4,0,0,0,1234,0,2.5,", 0), 0u) << row1;
  EXPECT_EQ(row2.rfind("2,0.002,", 0), 0u) << row2;
  // Columns added later go at the end, so scripts that read the first ones keep working.
  EXPECT_NE(header.find(",kinetic_energy,boundary_pressure_work"), std::string::npos) << header;
  EXPECT_NE(row1.find(",0.25,-0.125"), std::string::npos) << row1;
  EXPECT_NE(header.find(",density_residual_first,density_residual_peak,density_residual_last"), std::string::npos);
  EXPECT_NE(row1.find(",0.5,0.75,0.125,"), std::string::npos) << row1;  // first, peak, last
  EXPECT_NE(row2.find(",,,"), std::string::npos) << row2;               // no density solve
  EXPECT_NE(header.find(",density_residual_last,wall_guarded,wall_guard_max_shift"), std::string::npos);
  EXPECT_EQ(row1.substr(row1.size() - 24), ",0.5,0.75,0.125,3,0.0025") << row1;
  EXPECT_EQ(row2.substr(row2.size() - 6), ",,,0,0") << row2;
  const auto columns = [](const std::string& line) { return std::count(line.begin(), line.end(), ',') + 1; };
  EXPECT_EQ(columns(row1), columns(header));
}

TEST(RunStatistics, MeansAndTailWrench)
{
  io::RunStatistics stats({"tank", "ball"});
  for (int s = 1; s <= 20; ++s)
  {
    StepReport r;
    r.dt = 0.01;
    r.time = 0.01 * s;
    r.divergence_iterations = 1;
    r.density_iterations = s % 2 == 0 ? 4 : 2;
    r.density_error = 0.001 * s;
    r.density_converged = s != 5;                       // one step at max_iterations
    r.divergence_converged = s % 4 != 0;                // five
    r.wall_guarded = s % 10 == 0 ? std::size_t(s) : 0;  // steps 10 and 20
    r.wall_guard_max_shift = s % 10 == 0 ? 1e-4 * s : 0.0;
    const io::Wrench tank{Vec3d(s, 0, 0), Vec3d(0, 0, 2.0 * s)};
    const io::Wrench ball{Vec3d(0, 0, -1), Vec3d::Zero()};
    stats.add(r, 1.5, {tank, ball});
  }
  EXPECT_THROW(stats.add(StepReport{}, 1.0, {}), std::invalid_argument);

  io::RunSummary summary;
  stats.fill(summary);
  EXPECT_EQ(summary.steps, 20u);
  EXPECT_DOUBLE_EQ(summary.simulated_time, 0.2);
  EXPECT_NEAR(summary.step_time, 0.03, 1e-12);
  EXPECT_NEAR(summary.msPerStep(), 1.5, 1e-12);
  EXPECT_DOUBLE_EQ(summary.mean_divergence_iterations, 1.0);
  EXPECT_DOUBLE_EQ(summary.mean_density_iterations, 3.0);
  EXPECT_NEAR(summary.mean_density_error, 0.0105, 1e-12);
  EXPECT_NEAR(summary.max_density_error, 0.02, 1e-12);
  EXPECT_EQ(summary.density_not_converged_steps, 1u);
  EXPECT_EQ(summary.divergence_not_converged_steps, 5u);
  EXPECT_EQ(summary.wall_guarded_steps, 2u);
  EXPECT_EQ(summary.wall_guarded_particles, 30u);
  EXPECT_DOUBLE_EQ(summary.wall_guard_max_shift, 2e-3);
  const std::string json = io::toJson(summary);
  EXPECT_NE(json.find("\"wall_guarded_particles\": 30"), std::string::npos) << json;
  ASSERT_EQ(summary.bodies.size(), 2u);
  EXPECT_EQ(summary.bodies[0].name, "tank");
  EXPECT_TRUE(summary.bodies[0].last.force.isApprox(Vec3d(20, 0, 0)));
  // Last tenth of 0.2 s: the steps ending at 0.19 and 0.2 s.
  EXPECT_TRUE(summary.bodies[0].mean.force.isApprox(Vec3d(19.5, 0, 0)));
  EXPECT_TRUE(summary.bodies[0].mean.torque.isApprox(Vec3d(0, 0, 39)));
  EXPECT_TRUE(summary.bodies[1].mean.force.isApprox(Vec3d(0, 0, -1)));
}

TEST(RunSummary, JsonHasContractFields)
{
  test::TempDir dir;
  io::RunSummary s;
  s.scene = "scenes/dam.yaml";
  s.method = "mls";
  s.spacing = 0.02;
  s.threads = 2;
  s.status = "unstable";
  s.reason = "density error 0.5 > 0.1";
  s.initial_fluid_particles = 100;
  s.final_fluid_particles = 98;
  s.removed_at_start = 3;
  s.removed_total = 2;
  s.boundary_particles = 400;
  s.steps = 10;
  s.simulated_time = 0.01;
  s.wall_time = 0.02;
  s.step_time = 0.015;
  s.bodies.push_back({"tank", {Vec3d(1, 2, 3), Vec3d(4, 5, 6)}, {Vec3d(0.5, 1, 1.5), Vec3d(2, 2.5, 3)}});
  const std::string path = dir.file("summary.json");
  io::writeSummaryJson(path, s);

  const nlohmann::json j = nlohmann::json::parse(test::readFile(path));
  for (const char* key : {"summary_version",
                          "scene",
                          "method",
                          "spacing",
                          "threads",
                          "status",
                          "reason",
                          "fluid_particles",
                          "boundary_particles",
                          "steps",
                          "simulated_time_s",
                          "wall_time_s",
                          "step_time_s",
                          "ms_per_step",
                          "real_time_factor",
                          "mean_divergence_iterations",
                          "mean_density_iterations",
                          "mean_density_error",
                          "max_density_error",
                          "density_not_converged_steps",
                          "divergence_not_converged_steps",
                          "bodies"})
    EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_EQ(j["scene"], "scenes/dam.yaml");
  EXPECT_EQ(j["method"], "mls");
  EXPECT_EQ(j["status"], "unstable");
  EXPECT_EQ(j["reason"], "density error 0.5 > 0.1");
  EXPECT_EQ(j["fluid_particles"]["initial"], 100);
  EXPECT_EQ(j["fluid_particles"]["final"], 98);
  EXPECT_EQ(j["fluid_particles"]["removed_at_start"], 3);
  EXPECT_EQ(j["fluid_particles"]["removed_total"], 2);
  EXPECT_EQ(j["boundary_particles"], 400);
  EXPECT_DOUBLE_EQ(j["real_time_factor"].get<double>(), 0.5);
  EXPECT_DOUBLE_EQ(j["ms_per_step"].get<double>(), 1.5);
  ASSERT_EQ(j["bodies"].size(), 1u);
  const auto& body = j["bodies"][0];
  EXPECT_EQ(body["name"], "tank");
  EXPECT_EQ(body["force"], nlohmann::json({1.0, 2.0, 3.0}));
  EXPECT_EQ(body["torque"], nlohmann::json({4.0, 5.0, 6.0}));
  EXPECT_EQ(body["mean_force"], nlohmann::json({0.5, 1.0, 1.5}));
  EXPECT_EQ(body["mean_torque"], nlohmann::json({2.0, 2.5, 3.0}));
}

TEST(BodiesCsvWriter, HeaderAndOneRowPerFreeBody)
{
  test::TempDir dir;
  const std::string path = dir.file("bodies.csv");
  BodyInfo tank;  // not free: no row
  tank.name = "tank";
  BodyInfo raft;
  raft.name = "raft";
  raft.free = true;
  raft.mass = 2.0;
  raft.center_of_mass = Vec3d(0.1, 0.2, 0.3);
  raft.pose.translation = Vec3d(9, 9, 9);                        // the origin is not written: the centre of mass is
  raft.pose.rotation = Eigen::Quaterniond(0.5, 0.5, -0.5, 0.5);  // w, x, y, z
  raft.com_velocity = Vec3d(1, 2, 3);
  raft.linear_velocity = Vec3d(7, 7, 7);  // of the origin: not written
  raft.angular_velocity = Vec3d(4, 5, 6);
  raft.force = Vec3d(-1, -2, -3);
  raft.torque = Vec3d(8, 8, 8);  // about the origin: not written
  raft.torque_com = Vec3d(0.25, 0.5, 0.75);
  {
    io::BodiesCsvWriter csv(path);
    csv.write(0.0, {tank, raft});
    raft.center_of_mass.z() = 0.123456789012;  // written to 9 significant digits
    csv.write(0.05, {tank, raft});
    csv.write(0.1, {tank});  // no free body: no row
    csv.flush();
  }
  std::istringstream lines(test::readFile(path));
  std::string header, row1, row2, extra;
  std::getline(lines, header);
  std::getline(lines, row1);
  std::getline(lines, row2);
  EXPECT_FALSE(std::getline(lines, extra)) << extra;
  EXPECT_EQ(header, "t,body,x,y,z,qx,qy,qz,qw,vx,vy,vz,wx,wy,wz,fx,fy,fz,tx,ty,tz");
  EXPECT_EQ(header, io::BodiesCsvWriter::header());
  EXPECT_EQ(row1, "0,raft,0.1,0.2,0.3,0.5,-0.5,0.5,0.5,1,2,3,4,5,6,-1,-2,-3,0.25,0.5,0.75");
  EXPECT_EQ(row2.rfind("0.05,raft,0.1,0.2,0.123456789,", 0), 0u) << row2;
  EXPECT_THROW(io::BodiesCsvWriter(dir.file("no/such/dir/bodies.csv")), std::runtime_error);
}

TEST(CsvField, QuotesWhatWouldShiftTheColumns)
{
  // A body may be named "a,b" (the runner accepts it): written bare, it shifted bodies.csv's
  // columns by one for every CSV reader.
  EXPECT_EQ(io::csvField("crate"), "crate");
  EXPECT_EQ(io::csvField("a,b"), "\"a,b\"");
  EXPECT_EQ(io::csvField("say \"hi\""), "\"say \"\"hi\"\"\"");
  EXPECT_EQ(io::csvField("two\nlines"), "\"two\nlines\"");
}

TEST(RunSummary, FreeBodiesOnlyWhenThereAreAny)
{
  io::RunSummary s;
  EXPECT_FALSE(nlohmann::json::parse(io::toJson(s)).contains("free_bodies"));
  io::FreeBodySummary raft;
  raft.name = "raft";
  raft.center_of_mass = Vec3d(0.1, 0.2, 0.3);
  raft.orientation = Eigen::Quaterniond(0.5, 0.5, -0.5, 0.5);  // w, x, y, z
  raft.linear_velocity = Vec3d(1, 2, 3);
  raft.angular_velocity = Vec3d(4, 5, 6);
  raft.mass = 2.5;
  s.free_bodies.push_back(raft);
  raft.name = "hull";
  s.free_bodies.push_back(raft);
  const nlohmann::json j = nlohmann::json::parse(io::toJson(s));
  ASSERT_TRUE(j.contains("free_bodies"));
  ASSERT_TRUE(j["free_bodies"].is_object());
  EXPECT_EQ(j["free_bodies"].size(), 2u);
  const auto& b = j["free_bodies"]["raft"];
  EXPECT_EQ(b["center_of_mass"], nlohmann::json({0.1, 0.2, 0.3}));
  EXPECT_EQ(b["orientation"], nlohmann::json({0.5, -0.5, 0.5, 0.5}));  // qx, qy, qz, qw
  EXPECT_EQ(b["linear_velocity"], nlohmann::json({1.0, 2.0, 3.0}));
  EXPECT_EQ(b["angular_velocity"], nlohmann::json({4.0, 5.0, 6.0}));
  EXPECT_DOUBLE_EQ(b["mass"].get<double>(), 2.5);
  EXPECT_TRUE(j["free_bodies"].contains("hull"));
}

}  // namespace
}  // namespace fluid_sim
