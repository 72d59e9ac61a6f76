#include "fluid_sim/io/urdf_loader.h"

#include <console_bridge/console.h>
#include <tinyxml2.h>
#include <urdf_parser/urdf_parser.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <mutex>
#include <set>
#include <sstream>

#include "fluid_sim/core/mesh_inside_index.h"
#include "fluid_sim/io/file_util.h"
#include "fluid_sim/io/mesh_loader.h"
#include "fluid_sim/io/message_names.h"

namespace fluid_sim
{
namespace io
{
namespace fs = std::filesystem;

namespace
{
/// Collects what urdfdom reports through console_bridge while it parses, so that the reason a URDF
/// does not parse ends up in the exception rather than on the console. console_bridge's handler is
/// process-wide: the mutex keeps two parses in io from swapping it at once.
class CapturedConsole : public console_bridge::OutputHandler
{
public:
  CapturedConsole() : lock_(mutex())
  {
    console_bridge::useOutputHandler(this);
  }
  ~CapturedConsole() override
  {
    console_bridge::restorePreviousOutputHandler();
  }
  CapturedConsole(const CapturedConsole&) = delete;
  CapturedConsole& operator=(const CapturedConsole&) = delete;

  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override
  {
    if (level >= console_bridge::CONSOLE_BRIDGE_LOG_ERROR) errors_ += (errors_.empty() ? "" : "; ") + text;
  }
  const std::string& errors() const
  {
    return errors_;
  }

private:
  static std::mutex& mutex()
  {
    static std::mutex m;
    return m;
  }
  std::lock_guard<std::mutex> lock_;
  std::string errors_;
};

Vec3d toVec(const urdf::Vector3& v)
{
  return Vec3d(v.x, v.y, v.z);
}

Pose toPose(const urdf::Pose& p)
{
  return Pose::fromTranslationQuaternion(toVec(p.position), p.rotation.w, p.rotation.x, p.rotation.y, p.rotation.z);
}

bool finite(const Pose& p)
{
  return p.translation.allFinite() && p.rotation.coeffs().allFinite();
}

std::string describe(const Pose& p)
{
  std::ostringstream os;
  os << "xyz [" << p.translation.x() << ", " << p.translation.y() << ", " << p.translation.z() << "], quaternion (w "
     << p.rotation.w() << ", x " << p.rotation.x() << ", y " << p.rotation.y() << ", z " << p.rotation.z() << ")";
  return os.str();
}

/// A URDF origin (urdfdom refuses "nan" and "inf" in the text, but not what its own rpy
/// conversion or a later product makes of huge finite values): finite, else an error naming
/// the URDF and `where`.
void requireFinite(const Pose& p, const std::string& source, const std::string& where)
{
  if (!finite(p)) throw ConfigError(source, where + ": origin is not finite (" + describe(p) + ")");
}

/// "link 'paddle', collision[1] (name 'blade')": where in the URDF a problem is.
/// " (URDF line N)", or nothing when the line is not known: the scene loader appends the scene's
/// own line to the same message, so the URDF's says whose it is.
std::string urdfLine(int line)
{
  return line > 0 ? " (URDF line " + std::to_string(line) + ")" : std::string();
}

std::string elementName(const UrdfLink& link, std::size_t index)
{
  const UrdfCollision& c = link.collisions[index];
  return "link '" + link.name + "', collision[" + std::to_string(index) + "]" +
         (c.name.empty() ? std::string() : " ('" + c.name + "')") + urdfLine(c.line ? c.line : link.line);
}

/// Rotation that maps the coordinate axes onto coordinate axes (within 1e-9): a box so rotated is
/// still axis-aligned.
bool permutesAxes(const Eigen::Quaterniond& q)
{
  const Mat3d r = q.toRotationMatrix();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
    {
      const double a = std::abs(r(i, j));
      if (a > 1e-9 && std::abs(a - 1.0) > 1e-9) return false;
    }
  return true;
}

}  // namespace

const UrdfLink* UrdfRobot::link(const std::string& name) const
{
  for (const auto& l : links)
    if (l.name == name) return &l;
  return nullptr;
}

const UrdfJoint* UrdfRobot::joint(const std::string& name) const
{
  for (const auto& j : joints)
    if (j.name == name) return &j;
  return nullptr;
}

std::vector<std::string> UrdfRobot::collisionLinks() const
{
  std::vector<std::string> names;
  for (const auto& l : links)
    if (!l.collisions.empty()) names.push_back(l.name);
  return names;
}

namespace
{
/// The number of <collision> elements of each <link> in the URDF's text: urdfdom leaves out a
/// collision it cannot read (a mesh scale of one number, a cylinder without a length) and
/// reports it only on its console, so a link could lose its geometry and vanish from the water.
/// Where the file writes each link, its collision elements and each joint (tinyxml2 line
/// numbers; urdfdom keeps none), and how many collision elements each link has: urdfdom drops all
/// of a link's collisions when one cannot be parsed, and says so only on its console.
struct WrittenElements
{
  struct Link
  {
    int line = 0;
    std::vector<int> collision_lines;
  };
  std::map<std::string, Link> links;
  std::map<std::string, int> joint_lines;
};

WrittenElements writtenElements(const std::string& xml)
{
  WrittenElements out;
  tinyxml2::XMLDocument doc;
  if (doc.Parse(xml.c_str(), xml.size()) != tinyxml2::XML_SUCCESS) return out;
  const tinyxml2::XMLElement* robot = doc.FirstChildElement("robot");
  if (!robot) return out;
  for (const auto* link = robot->FirstChildElement("link"); link; link = link->NextSiblingElement("link"))
  {
    const char* name = link->Attribute("name");
    if (!name) continue;
    WrittenElements::Link& entry = out.links[name];
    entry.line = link->GetLineNum();
    for (const auto* c = link->FirstChildElement("collision"); c; c = c->NextSiblingElement("collision"))
      entry.collision_lines.push_back(c->GetLineNum());
  }
  for (const auto* joint = robot->FirstChildElement("joint"); joint; joint = joint->NextSiblingElement("joint"))
    if (const char* name = joint->Attribute("name")) out.joint_lines[name] = joint->GetLineNum();
  return out;
}
}  // namespace

UrdfRobot parseUrdf(const std::string& xml, const std::string& source, const std::string& base_dir)
{
  urdf::ModelInterfaceSharedPtr model;
  std::string reason;
  {
    CapturedConsole console;
    try
    {
      model = urdf::parseURDF(xml);
    }
    catch (const std::exception& e)  // urdfdom throws for some malformed numbers
    {
      reason = e.what();
    }
    if (reason.empty()) reason = console.errors();
  }
  if (!model)
  {
    // An XML error has a line urdfdom does not report: tinyxml2's own parse finds it.
    tinyxml2::XMLDocument doc;
    std::string where;
    if (doc.Parse(xml.c_str(), xml.size()) != tinyxml2::XML_SUCCESS) where = urdfLine(doc.ErrorLineNum());
    throw ConfigError(source, "not a valid URDF" + where + (reason.empty() ? std::string() : ": " + reason));
  }

  const WrittenElements written = writtenElements(xml);
  UrdfRobot robot;
  robot.name = model->getName();
  robot.source = source;
  robot.base_dir = base_dir;
  if (model->getRoot()) robot.root_link = model->getRoot()->name;
  // urdfdom keeps links and joints in maps (sorted by name); that order is as good as any.
  for (const auto& [name, link] : model->links_)
  {
    UrdfLink out;
    out.name = name;
    const auto written_link = written.links.find(name);
    const std::size_t written_count =
        written_link == written.links.end() ? 0 : written_link->second.collision_lines.size();
    if (written_link != written.links.end()) out.line = written_link->second.line;
    std::vector<urdf::CollisionSharedPtr> collisions = link->collision_array;
    if (collisions.empty() && link->collision) collisions.push_back(link->collision);
    for (const auto& c : collisions)
    {
      if (!c || !c->geometry) continue;
      UrdfCollision e;
      e.name = c->name;
      // urdfdom keeps a link's collisions in the file's order (all or none of them: below).
      if (out.collisions.size() < written_count) e.line = written_link->second.collision_lines[out.collisions.size()];
      e.origin = toPose(c->origin);
      requireFinite(e.origin, source,
                    "link '" + name + "', collision[" + std::to_string(out.collisions.size()) + "]" +
                        urdfLine(e.line ? e.line : out.line));
      switch (c->geometry->type)
      {
        case urdf::Geometry::BOX:
          e.type = UrdfCollision::Type::Box;
          e.size = toVec(static_cast<const urdf::Box&>(*c->geometry).dim);
          break;
        case urdf::Geometry::CYLINDER:
        {
          const auto& g = static_cast<const urdf::Cylinder&>(*c->geometry);
          e.type = UrdfCollision::Type::Cylinder;
          e.radius = g.radius;
          e.length = g.length;
          break;
        }
        case urdf::Geometry::SPHERE:
          e.type = UrdfCollision::Type::Sphere;
          e.radius = static_cast<const urdf::Sphere&>(*c->geometry).radius;
          break;
        case urdf::Geometry::MESH:
        {
          const auto& g = static_cast<const urdf::Mesh&>(*c->geometry);
          e.type = UrdfCollision::Type::Mesh;
          e.filename = g.filename;
          e.scale = toVec(g.scale);
          break;
        }
      }
      out.collisions.push_back(e);
    }
    if (out.collisions.size() < written_count)
      throw ConfigError(source, "link '" + name + "'" + urdfLine(out.line) + ": " +
                                    std::to_string(written_count - out.collisions.size()) + " of its " +
                                    std::to_string(written_count) + " collision elements could not be read" +
                                    (reason.empty() ? std::string(" (malformed geometry)") : ": " + reason));
    robot.links.push_back(std::move(out));
  }
  for (const auto& [name, joint] : model->joints_)
  {
    UrdfJoint j;
    j.name = name;
    const auto line = written.joint_lines.find(name);
    if (line != written.joint_lines.end()) j.line = line->second;
    const std::string joint_name = "joint '" + name + "'" + urdfLine(j.line);
    switch (joint->type)
    {
      case urdf::Joint::REVOLUTE:
        j.type = UrdfJointType::Revolute;
        break;
      case urdf::Joint::CONTINUOUS:
        j.type = UrdfJointType::Continuous;
        break;
      case urdf::Joint::PRISMATIC:
        j.type = UrdfJointType::Prismatic;
        break;
      case urdf::Joint::FLOATING:
        j.type = UrdfJointType::Floating;
        break;
      case urdf::Joint::PLANAR:
        j.type = UrdfJointType::Planar;
        break;
      default:
        j.type = UrdfJointType::Fixed;
        break;
    }
    j.parent = joint->parent_link_name;
    j.child = joint->child_link_name;
    j.origin = toPose(joint->parent_to_joint_origin_transform);
    requireFinite(j.origin, source, joint_name);
    const Vec3d axis = toVec(joint->axis);
    const double axis_norm = axis.stableNorm();
    if (!std::isfinite(axis_norm)) throw ConfigError(source, joint_name + ": axis is not a finite direction");
    j.axis = axis_norm > 0.0 ? Vec3d(axis / axis_norm) : Vec3d::UnitX();
    if (joint->limits && (j.type == UrdfJointType::Revolute || j.type == UrdfJointType::Prismatic))
    {
      j.has_limits = joint->limits->lower < joint->limits->upper;
      j.lower = joint->limits->lower;
      j.upper = joint->limits->upper;
    }
    if (joint->mimic)
    {
      j.mimic = joint->mimic->joint_name;
      j.mimic_multiplier = joint->mimic->multiplier;
      j.mimic_offset = joint->mimic->offset;
      if (!std::isfinite(j.mimic_multiplier) || !std::isfinite(j.mimic_offset))
        throw ConfigError(source, joint_name + ": mimic multiplier and offset must be finite");
    }
    robot.joints.push_back(j);
  }
  return robot;
}

UrdfRobot readUrdfFile(const std::string& path)
{
  return parseUrdf(readTextFile(path, "URDF file"), path, fs::path(path).parent_path().string());
}

std::map<std::string, Pose> linkPoses(const UrdfRobot& robot, const JointPositions& positions, const Pose& root_pose,
                                      std::vector<std::string>* warnings)
{
  std::vector<std::string> joint_names;
  for (const auto& j : robot.joints) joint_names.push_back(j.name);
  for (const auto& [name, value] : positions)
  {
    const UrdfJoint* j = robot.joint(name);
    if (!j)
      throw ConfigError(robot.source,
                        "unknown joint '" + name + "' (joints: " + joinNames(joint_names, ", ", "none") + ")");
    if (j->type == UrdfJointType::Fixed || j->type == UrdfJointType::Floating || j->type == UrdfJointType::Planar)
      throw ConfigError(robot.source, "joint '" + name + "'" + urdfLine(j->line) + " is " +
                                          (j->type == UrdfJointType::Fixed ? "fixed" : "floating or planar") +
                                          ": it has no single position to set");
    if (!std::isfinite(value))
      throw ConfigError(robot.source, "joint '" + name + "'" + urdfLine(j->line) + ": position must be finite");
  }
  // Position of a joint: given, else its mimic leader's (transformed), else 0.
  const auto position = [&](const UrdfJoint& joint) {
    const UrdfJoint* j = &joint;
    double multiplier = 1.0, offset = 0.0;
    for (int depth = 0; depth < 64; ++depth)
    {
      const auto it = positions.find(j->name);
      if (it != positions.end()) return multiplier * it->second + offset;
      const UrdfJoint* leader = j->mimic.empty() ? nullptr : robot.joint(j->mimic);
      if (!leader) break;
      offset += multiplier * j->mimic_offset;
      multiplier *= j->mimic_multiplier;
      j = leader;
    }
    return offset;
  };
  std::map<std::string, Pose> poses;
  if (robot.root_link.empty()) return poses;
  if (!finite(root_pose))
    throw ConfigError(robot.source,
                      "root link '" + robot.root_link + "': pose is not finite (" + describe(root_pose) + ")");
  poses[robot.root_link] = root_pose;
  // Breadth first from the root: a child's pose follows its parent's.
  std::vector<std::string> frontier = {robot.root_link};
  while (!frontier.empty())
  {
    std::vector<std::string> next;
    for (const auto& parent : frontier)
      for (const auto& j : robot.joints)
      {
        if (j.parent != parent || poses.count(j.child)) continue;
        const double q = position(j);
        Pose motion;
        if (j.type == UrdfJointType::Revolute || j.type == UrdfJointType::Continuous)
          motion.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(q, j.axis));
        else if (j.type == UrdfJointType::Prismatic)
          motion.translation = q * j.axis;
        if (warnings && j.has_limits && (q < j.lower - 1e-12 || q > j.upper + 1e-12))
          warnings->push_back(robot.source + ": joint '" + j.name + "' at " + std::to_string(q) +
                              " lies outside its limits [" + std::to_string(j.lower) + ", " + std::to_string(j.upper) +
                              "]; used as given");
        poses[j.child] = poses[parent] * j.origin * motion;
        // Finite origins and positions can still add up to infinity along a chain.
        if (!finite(poses[j.child]))
          throw ConfigError(robot.source, "link '" + j.child + "': its pose (through joint '" + j.name + "'" +
                                              urdfLine(j.line) + " at " + std::to_string(q) + ") is not finite (" +
                                              describe(poses[j.child]) + ")");
        next.push_back(j.child);
      }
    frontier.swap(next);
  }
  return poses;
}

LinkSurface linkSurface(const UrdfRobot& robot, const UrdfLink& link, double spacing, const PackageResolver& packages)
{
  const double max_error = 0.05 * spacing;  // m, facet error of tessellated cylinders and spheres
  LinkSurface out;
  for (std::size_t i = 0; i < link.collisions.size(); ++i)
  {
    const UrdfCollision& c = link.collisions[i];
    const std::string where = robot.source + ": " + elementName(link, i);
    TriangleMesh part;
    switch (c.type)
    {
      case UrdfCollision::Type::Box:
        if (!(c.size.minCoeff() > 0.0) || !c.size.allFinite())
          throw ConfigError(where, "box size must be > 0 on every axis");
        part = boxMesh(c.size);
        break;
      case UrdfCollision::Type::Cylinder:
        if (!(c.radius > 0.0 && c.length > 0.0) || !std::isfinite(c.radius * c.length))
          throw ConfigError(where, "cylinder radius and length must be > 0");
        part = cylinderMesh(c.radius, c.length, max_error);
        break;
      case UrdfCollision::Type::Sphere:
        if (!(c.radius > 0.0) || !std::isfinite(c.radius)) throw ConfigError(where, "sphere radius must be > 0");
        part = sphereMesh(c.radius, max_error);
        break;
      case UrdfCollision::Type::Mesh:
      {
        std::string path;
        MeshFile file;
        try
        {
          path = resolveResource(c.filename, robot.base_dir, packages);
          file = readMeshFile(path, c.scale);
        }
        catch (const ConfigError& e)
        {
          const std::string shown = path.empty() || path == c.filename ? c.filename : c.filename + " = " + path;
          throw ConfigError(where, "mesh " + shown + ": " + e.message());
        }
        out.closed = out.closed && file.closed;
        out.border_edges += file.border_edges;
        out.degenerate_triangles += file.degenerate_triangles;
        part = std::move(file.mesh);
        break;
      }
    }
    appendMesh(out.mesh, part, c.origin);
  }
  if (out.mesh.triangles.empty()) out.closed = false;
  buildInsideIndex(out.mesh);
  return out;
}

std::vector<BoundaryConfig> urdfBoundaries(const UrdfRobot& robot, const UrdfBoundaryOptions& options,
                                           std::vector<std::string>* warnings)
{
  // Without a list, every link with collision geometry: the others (a root or tool frame, a
  // sensor) are not asked for and are not warned about; a listed link without it is.
  std::vector<std::string> selected = options.links;
  if (selected.empty()) selected = robot.collisionLinks();
  std::vector<std::string> all_links;
  for (const auto& l : robot.links) all_links.push_back(l.name);
  std::set<std::string> seen;
  for (const auto& name : selected)
  {
    if (!robot.link(name))
      throw ConfigError(robot.source,
                        "unknown link '" + name + "' (links: " + joinNames(all_links, ", ", "none") + ")");
    if (!seen.insert(name).second) throw ConfigError(robot.source, "link '" + name + "' is listed twice");
  }
  const std::map<std::string, Pose> poses = linkPoses(robot, options.joint_positions, options.root_pose, warnings);

  std::vector<BoundaryConfig> out;
  for (const auto& name : selected)
  {
    const UrdfLink& link = *robot.link(name);
    if (link.collisions.empty())
    {
      if (warnings) warnings->push_back(robot.source + ": link '" + name + "' has no collision geometry; skipped");
      continue;
    }
    const bool thin = std::find(options.thin_links.begin(), options.thin_links.end(), name) != options.thin_links.end();
    BoundaryConfig b;
    b.name = name;
    b.pose = poses.count(name) ? poses.at(name) : options.root_pose;
    const UrdfCollision& only = link.collisions.front();
    const bool single = link.collisions.size() == 1;
    if (options.exact_primitives && single && only.type == UrdfCollision::Type::Sphere && only.radius > 0.0)
    {
      b.type = ShapeType::Sphere;
      b.sphere.center = only.origin.translation;
      b.sphere.radius = only.radius;
    }
    else if (options.exact_primitives && single && only.type == UrdfCollision::Type::Cylinder && only.radius > 0.0 &&
             only.length > 0.0)
    {
      b.type = ShapeType::Cylinder;
      b.cylinder.center = only.origin.translation;
      b.cylinder.axis = only.origin.rotation * Vec3d::UnitZ();
      b.cylinder.radius = only.radius;
      b.cylinder.length = only.length;
    }
    else if (options.exact_primitives && single && only.type == UrdfCollision::Type::Box &&
             only.size.minCoeff() > 0.0 && permutesAxes(only.origin.rotation))
    {
      const Vec3d half = 0.5 * (only.origin.rotation.toRotationMatrix().cwiseAbs() * only.size);
      b.type = ShapeType::Box;
      b.box.min = only.origin.translation - half;
      b.box.max = only.origin.translation + half;
    }
    else
    {
      LinkSurface surface = linkSurface(robot, link, options.spacing, options.packages);
      b.type = ShapeType::Mesh;
      b.mesh = std::move(surface.mesh);
      b.mesh_closed = surface.closed;
      if (warnings)
        for (auto& note :
             surfaceNotes(robot.source + ": link '" + name + "'", surface.closed || options.thin_shells_meant || thin,
                          surface.border_edges, surface.degenerate_triangles))
          warnings->push_back(std::move(note));
    }
    if (thin) b.mesh_offset = SurfaceOffset::None;
    out.push_back(std::move(b));
  }
  return out;
}

}  // namespace io
}  // namespace fluid_sim
