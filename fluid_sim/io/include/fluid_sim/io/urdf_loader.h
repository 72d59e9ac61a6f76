#pragma once
// URDF collision geometry into boundary bodies: one body per link, in the link frame, placed by
// forward kinematics at given joint positions. The URDF is parsed with urdfdom into the plain
// structs below (no urdfdom type leaves io); mesh files are read with readMeshFile(); package://
// URIs go through an injected PackageResolver. Visual geometry is ignored.

#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include "fluid_sim/core/scene_config.h"
#include "fluid_sim/core/types.h"
#include "fluid_sim/io/resource_resolver.h"

namespace fluid_sim
{
namespace io
{
/// One <collision> element.
struct UrdfCollision
{
  enum class Type
  {
    Box,
    Cylinder,
    Sphere,
    Mesh
  };
  Type type = Type::Box;
  std::string name;             // the element's name attribute ("" if none)
  int line = 0;                 // the element's line in the URDF file (0: not known)
  Pose origin;                  // element frame in the link frame (<origin xyz rpy>)
  Vec3d size = Vec3d::Zero();   // m, box edge lengths
  double radius = 0.0;          // m, cylinder and sphere
  double length = 0.0;          // m, cylinder (along the element's z axis)
  std::string filename;         // mesh, as written (package://, file:// or a path)
  Vec3d scale = Vec3d::Ones();  // mesh scale, unit-less
};

struct UrdfLink
{
  std::string name;
  int line = 0;  // the <link> element's line in the URDF file (0: not known)
  std::vector<UrdfCollision> collisions;
};

enum class UrdfJointType
{
  Fixed,
  Revolute,
  Continuous,
  Prismatic,
  Floating,
  Planar
};

struct UrdfJoint
{
  std::string name;
  int line = 0;  // the <joint> element's line in the URDF file (0: not known)
  UrdfJointType type = UrdfJointType::Fixed;
  std::string parent;           // parent link
  std::string child;            // child link
  Pose origin;                  // joint frame in the parent link frame at position 0
  Vec3d axis = Vec3d::UnitX();  // unit, joint frame
  bool has_limits = false;
  double lower = 0.0, upper = 0.0;  // rad or m, when has_limits
  std::string mimic;                // joint this one follows ("" if none)
  double mimic_multiplier = 1.0;    // unit-less: position = multiplier * leader + offset
  double mimic_offset = 0.0;        // rad or m
};

struct UrdfRobot
{
  std::string name;      // <robot name>
  std::string source;    // the URDF file (or the name given for a string), for messages
  std::string base_dir;  // folder that relative mesh file names are relative to
  std::string root_link;
  std::vector<UrdfLink> links;
  std::vector<UrdfJoint> joints;

  const UrdfLink* link(const std::string& name) const;    // nullptr if there is none
  const UrdfJoint* joint(const std::string& name) const;  // nullptr if there is none
  /// Names of the links with at least one collision element, in file order.
  std::vector<std::string> collisionLinks() const;
};

/// Parses URDF text. `source` names it in messages; relative mesh paths are relative to
/// `base_dir`. Throws ConfigError(source, ...) with urdfdom's reason if it does not parse.
UrdfRobot parseUrdf(const std::string& xml, const std::string& source, const std::string& base_dir = "");

/// Reads and parses a URDF file (relative mesh paths relative to its folder). Throws ConfigError
/// naming the file if it is missing, unreadable or does not parse.
UrdfRobot readUrdfFile(const std::string& path);

/// Joint positions by joint name: rad for revolute and continuous joints, m for prismatic ones.
using JointPositions = std::map<std::string, double>;

/// Pose of every link in the world at the given joint positions (absent joints at 0, a mimic joint
/// follows its leader unless given itself; fixed, floating and planar joints at their origin), the
/// root link at `root_pose`. Throws ConfigError(robot.source, ...) naming an unknown joint, or a
/// joint that has no single position (fixed, floating, planar). Positions beyond a joint's limits
/// are used as given and noted in `warnings` (if given).
std::map<std::string, Pose> linkPoses(const UrdfRobot& robot, const JointPositions& positions,
                                      const Pose& root_pose = Pose(), std::vector<std::string>* warnings = nullptr);

/// The collision surface of one link in the link frame, as one triangle mesh: boxes exactly (12
/// triangles), cylinders and spheres with facets within 0.05 * spacing of the true surface, mesh
/// files through readMeshFile() (scaled). Each part is oriented outward on its own; the mesh is
/// closed if every part is. Throws ConfigError naming the URDF file, the link, the element and
/// the mesh file for anything that cannot be read.
struct LinkSurface
{
  TriangleMesh mesh;                     // link frame, m; inside index built
  bool closed = true;                    // every part closed
  std::size_t degenerate_triangles = 0;  // summed over the mesh-file parts
  std::size_t border_edges = 0;          // summed over the mesh-file parts
};
LinkSurface linkSurface(const UrdfRobot& robot, const UrdfLink& link, double spacing, const PackageResolver& packages);

struct UrdfBoundaryOptions
{
  std::vector<std::string> links;  // links to use; empty = every link with collision geometry
  JointPositions joint_positions;  // rad / m by joint name; absent joints at 0
  Pose root_pose;                  // root link in the world
  double spacing = 0.02;           // m, the finest sample spacing the bodies will use (facet error)
  PackageResolver packages;        // for package:// URIs
  /// A link whose only collision element is a sphere, a cylinder, or a box whose edges are
  /// parallel to the link axes becomes that core primitive (exact surface and inside test, lattice
  /// sampling) instead of a tessellated mesh. Its frame is the link frame either way.
  bool exact_primitives = true;
  /// The scene says `offset: none`: open links are meant as thin shells and are not warned about.
  bool thin_shells_meant = false;
  /// Links meant as thin shells one by one (the node's ~thin_links): each gets mesh_offset None
  /// (its particle layer on the collision surface) and, if open, no warning. Names not among the
  /// bodies made are ignored here; the caller checks them against the result.
  std::vector<std::string> thin_links;
};

/// One BoundaryConfig per selected link, named after the link, pose = the link's pose in the world,
/// shape in the link frame (ShapeType::Mesh, or a primitive with exact_primitives). The other
/// fields keep their defaults. An unknown link name throws ConfigError naming it and the URDF
/// file; a selected link without collision geometry is skipped with a note in `warnings`, as are
/// open surfaces and degenerate triangles.
std::vector<BoundaryConfig> urdfBoundaries(const UrdfRobot& robot, const UrdfBoundaryOptions& options,
                                           std::vector<std::string>* warnings = nullptr);

}  // namespace io
}  // namespace fluid_sim
