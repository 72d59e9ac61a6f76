// URDF collision geometry into boundary bodies: shapes, origins and scales of the fixture robot,
// forward kinematics, and the errors for bad URDFs.

#include "fluid_sim/io/urdf_loader.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "fluid_sim/core/boundary_sampling.h"
#include "fluid_sim/io/mesh_topology.h"
#include "temp_dir.h"

namespace fluid_sim
{
namespace
{
const std::string kFixtures = FLUID_SIM_SOURCE_DIR "/test/fixtures";
const std::string kUrdf = kFixtures + "/fluid_sim_test_pkg/urdf/shapes.urdf";

io::UrdfBoundaryOptions fixtureOptions()
{
  io::UrdfBoundaryOptions o;
  o.spacing = 0.01;
  o.packages = io::defaultPackageResolver({kFixtures});
  return o;
}

const BoundaryConfig& byName(const std::vector<BoundaryConfig>& bodies, const std::string& name)
{
  for (const auto& b : bodies)
    if (b.name == name) return b;
  throw std::runtime_error("no body " + name);
}

template <typename F>
std::string errorOf(F&& f)
{
  try
  {
    f();
  }
  catch (const ConfigError& e)
  {
    return e.what();
  }
  return "";
}

bool near(const Vec3d& a, const Vec3d& b, double tol = 1e-9)
{
  return (a - b).norm() <= tol;
}

TEST(UrdfLoader, ParsesLinksJointsAndCollisionElements)
{
  const io::UrdfRobot robot = io::readUrdfFile(kUrdf);
  EXPECT_EQ(robot.name, "shapes");
  EXPECT_EQ(robot.root_link, "base");
  EXPECT_EQ(robot.links.size(), 8u);
  EXPECT_EQ(robot.joints.size(), 7u);
  const std::vector<std::string> with_collision = robot.collisionLinks();
  EXPECT_EQ(with_collision.size(), 7u);  // all but 'marker' (visual only)
  const io::UrdfLink& base = *robot.link("base");
  ASSERT_EQ(base.collisions.size(), 1u);  // the visual sphere is ignored
  EXPECT_EQ(base.collisions[0].type, io::UrdfCollision::Type::Box);
  EXPECT_TRUE(near(base.collisions[0].size, Vec3d(0.4, 0.3, 0.1)));
  const io::UrdfLink& part = *robot.link("part");
  EXPECT_EQ(part.collisions[0].type, io::UrdfCollision::Type::Mesh);
  EXPECT_EQ(part.collisions[0].filename, "package://fluid_sim_test_pkg/meshes/pyramid.obj");
  EXPECT_TRUE(near(part.collisions[0].scale, Vec3d(0.1, 0.2, 0.3)));
  EXPECT_EQ(robot.link("combo")->collisions.size(), 2u);
  EXPECT_EQ(robot.link("combo")->collisions[1].name, "knob");
  const io::UrdfJoint& cup = *robot.joint("cup_spin");
  EXPECT_EQ(cup.type, io::UrdfJointType::Continuous);
  EXPECT_EQ(cup.mimic, "drum_joint");
  EXPECT_DOUBLE_EQ(cup.mimic_multiplier, 2.0);
}

TEST(UrdfLoader, FixtureLinksBecomeBodiesWithTheRightShapes)
{
  const io::UrdfRobot robot = io::readUrdfFile(kUrdf);
  std::vector<std::string> notes;
  const std::vector<BoundaryConfig> bodies = io::urdfBoundaries(robot, fixtureOptions(), &notes);
  ASSERT_EQ(bodies.size(), 7u);

  // base: a box rotated 90 degrees about z stays an axis-aligned box in the link frame (0.3 x 0.4).
  const BoundaryConfig& base = byName(bodies, "base");
  ASSERT_EQ(base.type, ShapeType::Box);
  EXPECT_TRUE(near(base.box.min, Vec3d(-0.15, -0.2, 0.0)));
  EXPECT_TRUE(near(base.box.max, Vec3d(0.15, 0.2, 0.1)));
  EXPECT_TRUE(near(base.pose.translation, Vec3d::Zero()));

  // drum: cylinder along the element's z, which rpy (pi/2, 0, 0) turns to -y.
  const BoundaryConfig& drum = byName(bodies, "drum");
  ASSERT_EQ(drum.type, ShapeType::Cylinder);
  EXPECT_TRUE(near(drum.cylinder.center, Vec3d(0, 0, 0.1)));
  EXPECT_TRUE(near(drum.cylinder.axis, Vec3d(0, -1, 0)));
  EXPECT_DOUBLE_EQ(drum.cylinder.radius, 0.05);
  EXPECT_DOUBLE_EQ(drum.cylinder.length, 0.2);
  EXPECT_TRUE(near(drum.pose.translation, Vec3d(0.2, 0, 0.1)));

  const BoundaryConfig& ball = byName(bodies, "ball");
  ASSERT_EQ(ball.type, ShapeType::Sphere);
  EXPECT_TRUE(near(ball.sphere.center, Vec3d(0.01, 0.02, 0.03)));
  EXPECT_DOUBLE_EQ(ball.sphere.radius, 0.04);
  EXPECT_TRUE(near(ball.pose.translation, Vec3d(0.2, 0, 0.2)));

  // part: the pyramid (base 1 x 1 at z = 0, apex at z = 1) scaled (0.1, 0.2, 0.3), origin 0.1 up.
  const BoundaryConfig& part = byName(bodies, "part");
  ASSERT_EQ(part.type, ShapeType::Mesh);
  EXPECT_TRUE(part.mesh_closed);
  EXPECT_NEAR(io::signedVolume(part.mesh), 0.1 * 0.2 * 0.3 / 3.0, 1e-9);
  Vec3d lo = part.mesh.vertices[0], hi = lo;
  for (const auto& v : part.mesh.vertices)
  {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  EXPECT_TRUE(near(lo, Vec3d(-0.05, -0.1, 0.1), 1e-7)) << lo.transpose();
  EXPECT_TRUE(near(hi, Vec3d(0.05, 0.1, 0.4), 1e-7)) << hi.transpose();
  // Fixed joint: 0.3 along y, turned 90 degrees about z.
  EXPECT_TRUE(near(part.pose.translation, Vec3d(0, 0.3, 0)));
  EXPECT_TRUE(near(part.pose.rotation * Vec3d::UnitX(), Vec3d::UnitY()));

  const BoundaryConfig& cup = byName(bodies, "cup");
  ASSERT_EQ(cup.type, ShapeType::Mesh);
  EXPECT_FALSE(cup.mesh_closed);

  // combo: two elements, one mesh: a box turned 0.3 rad (12 triangles) and a tessellated sphere,
  // each closed and outward, overlapping; inside = their union.
  const BoundaryConfig& combo = byName(bodies, "combo");
  ASSERT_EQ(combo.type, ShapeType::Mesh);
  EXPECT_TRUE(combo.mesh_closed);
  EXPECT_GT(combo.mesh.triangles.size(), 12u);
  EXPECT_TRUE(insideShape(combo, Vec3d(0, 0, 0)));          // box only
  EXPECT_TRUE(insideShape(combo, Vec3d(0, 0, 0.045)));      // box and sphere
  EXPECT_TRUE(insideShape(combo, Vec3d(0, 0, 0.11)));       // sphere only
  EXPECT_FALSE(insideShape(combo, Vec3d(0, 0, 0.125)));     // above the sphere
  EXPECT_FALSE(insideShape(combo, Vec3d(0.06, 0.0, 0.0)));  // beyond the turned box's face

  // relative: a mesh path relative to the URDF's folder.
  const BoundaryConfig& relative = byName(bodies, "relative");
  EXPECT_NEAR(io::signedVolume(relative.mesh), 0.001, 1e-12);

  // 'marker' has no collision geometry: not asked for (no list: every link with collision
  // geometry), so not warned about (every URDF's root or tool frame was); listed, it is skipped
  // with a note naming the file.
  const auto markerNoted = [](const std::vector<std::string>& n) {
    return std::any_of(n.begin(), n.end(), [](const std::string& w) {
      return w.find("shapes.urdf: link 'marker' has no collision") != std::string::npos;
    });
  };
  EXPECT_FALSE(markerNoted(notes));
  io::UrdfBoundaryOptions listed = fixtureOptions();
  listed.links = {"base", "marker"};
  std::vector<std::string> listed_notes;
  EXPECT_EQ(io::urdfBoundaries(robot, listed, &listed_notes).size(), 1u);
  EXPECT_TRUE(markerNoted(listed_notes));
  bool cup_noted = false;
  for (const auto& n : notes)
    cup_noted = cup_noted || (n.find("link 'cup': not a closed surface") != std::string::npos);
  EXPECT_TRUE(cup_noted);
}

TEST(UrdfLoader, MeshesForEveryLinkWhenExactPrimitivesAreOff)
{
  io::UrdfBoundaryOptions o = fixtureOptions();
  o.exact_primitives = false;
  o.links = {"base", "drum", "ball"};
  const std::vector<BoundaryConfig> bodies = io::urdfBoundaries(io::readUrdfFile(kUrdf), o);
  ASSERT_EQ(bodies.size(), 3u);
  for (const auto& b : bodies)
  {
    EXPECT_EQ(b.type, ShapeType::Mesh) << b.name;
    EXPECT_TRUE(b.mesh_closed) << b.name;
  }
  EXPECT_EQ(byName(bodies, "base").mesh.triangles.size(), 12u);
  EXPECT_NEAR(io::signedVolume(byName(bodies, "base").mesh), 0.4 * 0.3 * 0.1, 1e-12);
  // Sphere of radius 0.04 tessellated within 0.05 spacing = 0.5 mm.
  const BoundaryConfig& ball = byName(bodies, "ball");
  for (const auto& v : ball.mesh.vertices) EXPECT_NEAR((v - Vec3d(0.01, 0.02, 0.03)).norm(), 0.04, 0.0005);
  const BoundaryConfig& drum = byName(bodies, "drum");
  EXPECT_TRUE(insideShape(drum, Vec3d(0, -0.095, 0.1)));  // along the axis (-y), inside
  EXPECT_FALSE(insideShape(drum, Vec3d(0, -0.105, 0.1)));
}

TEST(UrdfLoader, ForwardKinematicsAtJointPositions)
{
  const io::UrdfRobot robot = io::readUrdfFile(kUrdf);
  Pose root = Pose::fromXyzRpy(Vec3d(1, 2, 3), Vec3d::Zero());
  std::vector<std::string> notes;
  const auto poses = io::linkPoses(robot, {{"drum_joint", M_PI / 2}, {"ball_slide", 0.05}}, root, &notes);
  // drum turns 90 degrees about z at (0.2, 0, 0.1).
  EXPECT_TRUE(near(poses.at("drum").translation, Vec3d(1.2, 2, 3.1)));
  EXPECT_TRUE(near(poses.at("drum").rotation * Vec3d::UnitX(), Vec3d::UnitY()));
  // ball slides 0.05 along the drum's x (now world y), 0.1 above the drum.
  EXPECT_TRUE(near(poses.at("ball").translation, Vec3d(1.2, 2.05, 3.2)));
  // cup mimics drum_joint: 2 * pi/2 + 0.1 about z.
  const Vec3d cup_x = poses.at("cup").rotation * Vec3d::UnitX();
  EXPECT_NEAR(std::atan2(cup_x.y(), cup_x.x()), std::remainder(M_PI + 0.1, 2 * M_PI), 1e-9);
  // pi/2 is beyond drum_joint's limit of 1 rad: used, and noted.
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_NE(notes[0].find("joint 'drum_joint'"), std::string::npos) << notes[0];
  EXPECT_NE(notes[0].find("outside its limits"), std::string::npos) << notes[0];
  // Zero by default; the root at identity.
  const auto zero = io::linkPoses(robot, {});
  EXPECT_TRUE(near(zero.at("ball").translation, Vec3d(0.2, 0, 0.2)));
  EXPECT_TRUE(near(zero.at("base").translation, Vec3d::Zero()));
}

TEST(UrdfLoader, UnknownLinkAndJointNamesAreErrors)
{
  const io::UrdfRobot robot = io::readUrdfFile(kUrdf);
  io::UrdfBoundaryOptions o = fixtureOptions();
  o.links = {"base", "paddle"};
  const std::string link = errorOf([&] { io::urdfBoundaries(robot, o); });
  EXPECT_NE(link.find("shapes.urdf: unknown link 'paddle'"), std::string::npos) << link;
  o.links = {};
  o.joint_positions = {{"elbow", 0.3}};
  const std::string joint = errorOf([&] { io::urdfBoundaries(robot, o); });
  EXPECT_NE(joint.find("shapes.urdf: unknown joint 'elbow'"), std::string::npos) << joint;
  o.joint_positions = {{"part_mount", 0.3}};
  EXPECT_NE(errorOf([&] { io::urdfBoundaries(robot, o); }).find("joint 'part_mount' (URDF line 68) is fixed"),
            std::string::npos);
}

TEST(UrdfLoader, BadUrdfsGiveClearErrors)
{
  test::TempDir dir;
  const std::string missing = errorOf([&] { io::readUrdfFile(dir.file("robot.urdf")); });
  EXPECT_NE(missing.find("robot.urdf: no such file"), std::string::npos) << missing;

  const std::string syntax = errorOf([&] { io::parseUrdf("<robot name='r'><link name='a'>", "broken.urdf"); });
  EXPECT_NE(syntax.find("broken.urdf: not a valid URDF"), std::string::npos) << syntax;
  // An XML error says the URDF's line (urdfdom reports none).
  const std::string third =
      errorOf([&] { io::parseUrdf("<robot name='r'>\n<link name='a'/>\n<link name='b'></robot>", "l3.urdf"); });
  EXPECT_NE(third.find("l3.urdf: not a valid URDF (URDF line 3)"), std::string::npos) << third;
  const std::string no_root =
      errorOf([&] { io::parseUrdf("<robot name='r'><link name='a'/><link name='b'/></robot>", "two_roots.urdf"); });
  EXPECT_NE(no_root.find("two_roots.urdf: not a valid URDF"), std::string::npos) << no_root;
  EXPECT_NE(errorOf([&] { io::parseUrdf("hello", "text.urdf"); }).find("text.urdf: not a valid URDF"),
            std::string::npos);

  // A mesh that cannot be read: the message names the URDF, the link, the element and the mesh.
  const std::string xml = R"(<robot name="r">
  <link name="arm"><collision name="shell"><geometry><mesh filename="meshes/arm.stl"/></geometry></collision></link>
</robot>)";
  const io::UrdfRobot robot = io::parseUrdf(xml, dir.file("r.urdf"), dir.path().string());
  const std::string mesh = errorOf([&] { io::urdfBoundaries(robot, fixtureOptions()); });
  EXPECT_NE(mesh.find("r.urdf: link 'arm', collision[0] ('shell') (URDF line 2): mesh meshes/arm.stl"),
            std::string::npos)
      << mesh;
  EXPECT_NE(mesh.find("no such file"), std::string::npos) << mesh;

  const std::string package = R"(<robot name="r">
  <link name="arm"><collision><geometry><mesh filename="package://nowhere/arm.stl"/></geometry></collision></link>
</robot>)";
  const std::string unknown = errorOf([&] { io::urdfBoundaries(io::parseUrdf(package, "p.urdf"), fixtureOptions()); });
  EXPECT_NE(unknown.find("p.urdf: link 'arm', collision[0] (URDF line 2): mesh package://nowhere/arm.stl"),
            std::string::npos)
      << unknown;
  EXPECT_NE(unknown.find("unknown package 'nowhere'"), std::string::npos) << unknown;

  // Geometry urdfdom cannot read (a mesh scale of one number, a cylinder without a length): it
  // drops the link's collision elements (the good box too) and says so only on its console, and
  // the link vanished from the water with a warning that it had no collision geometry.
  for (const char* geometry : {"<mesh filename='arm.stl' scale='0.001'/>", "<cylinder radius='0.02'/>"})
  {
    const std::string bad = std::string("<robot name='r'><link name='arm'><collision><geometry>") + geometry +
                            "</geometry></collision><collision><geometry><box size='0.1 0.1 0.1'/></geometry>"
                            "</collision></link></robot>";
    const std::string dropped = errorOf([&] { io::parseUrdf(bad, "bad.urdf"); });
    EXPECT_NE(dropped.find("bad.urdf: link 'arm' (URDF line 1): 2 of its 2 collision elements could not be read"),
              std::string::npos)
        << geometry << ": " << dropped;
    EXPECT_NE(dropped.find("Could not parse collision element for Link [arm]"), std::string::npos) << dropped;
  }
}

TEST(UrdfLoader, NonFinitePosesAreErrorsNamingTheLink)
{
  // Each origin is finite (urdfdom refuses "nan" and "inf" in the text), but two of them add up
  // to infinity: the link would vanish with its water kept.
  const std::string chain = R"(<robot name="r">
  <link name="base"/>
  <link name="mid"/>
  <link name="tip"><collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>
  <joint name="j1" type="fixed"><parent link="base"/><child link="mid"/><origin xyz="1e308 0 0"/></joint>
  <joint name="j2" type="fixed"><parent link="mid"/><child link="tip"/><origin xyz="1e308 0 0"/></joint>
</robot>)";
  const std::string far = errorOf([&] { io::urdfBoundaries(io::parseUrdf(chain, "chain.urdf"), fixtureOptions()); });
  EXPECT_NE(far.find("chain.urdf: link 'tip'"), std::string::npos) << far;
  EXPECT_NE(far.find("joint 'j2' (URDF line 6)"), std::string::npos) << far;
  EXPECT_NE(far.find("not finite"), std::string::npos) << far;
  EXPECT_NE(far.find("inf"), std::string::npos) << far;

  // A NaN root pose (the scene's `pose` of a urdf entry, or a caller's).
  const std::string one = R"(<robot name="r">
  <link name="base"><collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>
</robot>)";
  io::UrdfBoundaryOptions o = fixtureOptions();
  o.root_pose = Pose::fromXyzRpy(Vec3d::Zero(), Vec3d(NAN, 0, 0));
  const std::string root = errorOf([&] { io::urdfBoundaries(io::parseUrdf(one, "one.urdf"), o); });
  EXPECT_NE(root.find("one.urdf: root link 'base': pose is not finite"), std::string::npos) << root;

  // A huge but finite axis is a direction like any other.
  const std::string axis = R"(<robot name="r">
  <link name="base"/>
  <link name="arm"><collision><origin xyz="0.5 0 0"/><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>
  <joint name="j" type="continuous"><parent link="base"/><child link="arm"/><axis xyz="0 0 1e200"/></joint>
</robot>)";
  o = fixtureOptions();
  o.joint_positions = {{"j", M_PI / 2}};
  const std::vector<BoundaryConfig> bodies = io::urdfBoundaries(io::parseUrdf(axis, "axis.urdf"), o);
  const BoundaryConfig& arm = byName(bodies, "arm");
  EXPECT_NEAR(arm.pose.rotation.norm(), 1.0, 1e-12);
  EXPECT_NEAR((arm.pose.rotation * Vec3d::UnitX() - Vec3d::UnitY()).norm(), 0.0, 1e-12);
}

TEST(UrdfLoader, UrdfFromAString)
{
  const std::string xml = R"(<robot name="r">
  <link name="base"><collision><geometry><sphere radius="0.1"/></geometry></collision></link>
  <link name="tool"><collision><origin rpy="0.3 0 0"/><geometry><box size="0.1 0.2 0.3"/></geometry></collision></link>
  <joint name="j" type="prismatic"><parent link="base"/><child link="tool"/><axis xyz="0 0 1"/>
    <limit lower="0" upper="1" effort="1" velocity="1"/></joint>
</robot>)";
  io::UrdfBoundaryOptions o = fixtureOptions();
  o.joint_positions = {{"j", 0.25}};
  const auto bodies = io::urdfBoundaries(io::parseUrdf(xml, "robot_description"), o);
  ASSERT_EQ(bodies.size(), 2u);
  const BoundaryConfig& tool = byName(bodies, "tool");
  EXPECT_EQ(tool.type, ShapeType::Mesh);  // a box turned by 0.3 rad is not axis-aligned
  EXPECT_EQ(tool.mesh.triangles.size(), 12u);
  EXPECT_TRUE(near(tool.pose.translation, Vec3d(0, 0, 0.25)));
}

}  // namespace
}  // namespace fluid_sim
