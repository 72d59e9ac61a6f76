// In-process checks of the ROS layer's conversions (no master needed).
#include <cstring>

#include <gtest/gtest.h>

#include "fluid_sim/io/scene_loader.h"
#include "fluid_sim/ros/messages.h"
#include "fluid_sim/ros/param_yaml.h"

using namespace fluid_sim;
using namespace fluid_sim::ros_bridge;

namespace
{
XmlRpc::XmlRpcValue vec(double a, double b, double c)
{
  XmlRpc::XmlRpcValue v;
  v.setSize(3);
  v[0] = a;
  v[1] = b;
  v[2] = c;
  return v;
}

float at(const sensor_msgs::PointCloud2& cloud, std::size_t point, std::size_t field)
{
  float v;
  std::memcpy(&v, &cloud.data[point * cloud.point_step + 4 * field], 4);
  return v;
}
}  // namespace

TEST(ParamYaml, PrivateParametersBecomeTheSceneTheLoaderChecks)
{
  // What <rosparam> makes of a scene file: nested structs, int and double numbers, strings.
  XmlRpc::XmlRpcValue p;
  p["spacing"] = 0.05;
  p["rest_density"] = 1000;  // an int: the loader takes it as a double
  XmlRpc::XmlRpcValue box;
  box["min"] = vec(0, 0, 0);
  box["max"] = vec(0.2, 0.2, 0.2);
  XmlRpc::XmlRpcValue block;
  block["box"] = box;
  p["fluid"].setSize(1);
  p["fluid"][0] = block;
  p["domain"]["min"] = vec(-0.5, -0.5, -0.5);
  p["domain"]["max"] = vec(1, 1, 1);
  p["solver"]["boundary_pressure"] = std::string("sph");
  p["solver"]["density_error"] = 0.0005;
  // Node keys are not scene keys.
  p["fixed_frame"] = std::string("odom");
  p["publish_rate"] = 10.0;
  const std::string yaml = sceneYaml(p, {"fixed_frame", "publish_rate"});
  EXPECT_EQ(yaml.find("fixed_frame"), std::string::npos) << yaml;

  const SceneConfig s = io::parseScene(yaml, "params");
  EXPECT_DOUBLE_EQ(s.spacing, 0.05);
  EXPECT_DOUBLE_EQ(s.rest_density, 1000.0);
  EXPECT_EQ(s.solver.boundary_pressure, BoundaryPressureMethod::SphExtrapolation);
  EXPECT_DOUBLE_EQ(s.solver.density_error, 0.0005);
  ASSERT_EQ(s.fluid.size(), 1u);
  EXPECT_DOUBLE_EQ(s.fluid[0].box.max.y(), 0.2);

  // A typo in a scene key is the loader's named error, as for a file.
  p["solver"]["density_eror"] = 0.001;
  try
  {
    io::parseScene(sceneYaml(p, {"fixed_frame", "publish_rate"}), "params");
    FAIL() << "typo accepted";
  }
  catch (const ConfigError& e)
  {
    EXPECT_NE(std::string(e.what()).find("solver.density_eror"), std::string::npos) << e.what();
  }
}

TEST(ParamYaml, StringsAreQuotedAndDoublesKeepTheirPrecision)
{
  XmlRpc::XmlRpcValue s(std::string("a \"b\": c\\d\n#e"));
  EXPECT_EQ(toYaml(s), "\"a \\\"b\\\": c\\\\d\\n#e\"");
  XmlRpc::XmlRpcValue d(0.1);
  EXPECT_EQ(toYaml(d), "0.10000000000000001");
  XmlRpc::XmlRpcValue one(1.0);
  EXPECT_EQ(toYaml(one), "1.0");
  XmlRpc::XmlRpcValue b(true);
  EXPECT_EQ(toYaml(b), "true");
}

TEST(Clouds, ParticleCloudHasTheDocumentedLayout)
{
  FluidSnapshot f;
  for (int i = 0; i < 10; ++i)
  {
    f.positions.push_back(Vec3(Real(i), Real(2 * i), Real(3 * i)));
    f.velocities.push_back(Vec3(Real(3), Real(4), Real(0)));
    f.pressures.push_back(Real(100 * i));
    f.densities.push_back(Real(1000 + i));
  }
  sensor_msgs::PointCloud2 cloud;
  fillParticleCloud(f, 0, cloud);
  ASSERT_EQ(cloud.width, 10u);
  EXPECT_EQ(cloud.height, 1u);
  EXPECT_EQ(cloud.point_step, 36u);
  EXPECT_EQ(cloud.row_step, 360u);
  ASSERT_EQ(cloud.fields.size(), 9u);
  EXPECT_EQ(cloud.fields[8].name, "speed");
  EXPECT_FLOAT_EQ(at(cloud, 7, 1), 14.0f);
  EXPECT_FLOAT_EQ(at(cloud, 7, 6), 700.0f);
  EXPECT_FLOAT_EQ(at(cloud, 7, 7), 1007.0f);
  EXPECT_FLOAT_EQ(at(cloud, 7, 8), 5.0f);

  // Decimated to at most 4 points: every third particle, spread over the whole fluid.
  fillParticleCloud(f, 4, cloud);
  ASSERT_EQ(cloud.width, 4u);
  EXPECT_EQ(cloud.data.size(), 4u * 36u);
  EXPECT_FLOAT_EQ(at(cloud, 0, 0), 0.0f);
  EXPECT_FLOAT_EQ(at(cloud, 3, 0), 9.0f);
}

TEST(Clouds, BoundaryCloudNamesEachParticlesBody)
{
  std::vector<Vec3> x(5, Vec3::Zero());
  std::vector<Real> p = {1, 2, 3, 4, 5};
  sensor_msgs::PointCloud2 cloud;
  fillBoundaryCloud(x, p, {{0, 2}, {2, 3}}, cloud);
  ASSERT_EQ(cloud.width, 5u);
  ASSERT_EQ(cloud.fields.size(), 5u);
  EXPECT_EQ(cloud.fields[4].name, "body");
  EXPECT_FLOAT_EQ(at(cloud, 1, 4), 0.0f);
  EXPECT_FLOAT_EQ(at(cloud, 2, 4), 1.0f);
  EXPECT_FLOAT_EQ(at(cloud, 4, 3), 5.0f);
}

TEST(Layers, CoreAndIoHeadersIncludeNoRos)
{
  // The layering rule (ARCHITECTURE.md): nothing under core or io includes ROS. Checked on the
  // sources, since a stray include would compile here, where ROS is present.
  for (const char* dir : {"fluid_sim/core", "fluid_sim/io"})
  {
    const std::string cmd =
        std::string("grep -rlE '#include [<\"](ros/|tf2|sensor_msgs|geometry_msgs|fluid_msgs|xmlrpcpp)' ") +
        FLUID_SIM_SOURCE_DIR + "/" + dir + " 2>/dev/null";
    FILE* pipe = popen(cmd.c_str(), "r");
    ASSERT_NE(pipe, nullptr);
    char buf[512];
    std::string found;
    while (fgets(buf, sizeof buf, pipe)) found += buf;
    pclose(pipe);
    EXPECT_EQ(found, "") << dir << " includes ROS headers";
  }
}
