#include "fluid_sim/io/scene_loader.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <optional>
#include <set>
#include <sstream>
#include <vector>

#include "fluid_sim/core/boundary_sampling.h"
#include "fluid_sim/core/mesh_inside_index.h"
#include "fluid_sim/io/mesh_loader.h"
#include "fluid_sim/io/mesh_topology.h"
#include "fluid_sim/io/urdf_loader.h"

namespace fluid_sim
{
namespace io
{
SceneError::SceneError(const std::string& file, const std::string& key, const std::string& message)
    : ConfigError(key, message), file_(file), what_(file + ": " + std::runtime_error::what())
{
}

namespace
{
// ------------------------------------------------------------------------------------ messages

/// A YAML value and its dotted key path ("boundaries[1].sphere.radius"), for messages.
struct Entry
{
  YAML::Node node;
  std::string key;
};

std::string childKey(const std::string& parent, const std::string& name)
{
  return parent.empty() ? name : parent + "." + name;
}

std::string indexKey(const std::string& parent, std::size_t index)
{
  return parent + "[" + std::to_string(index) + "]";
}

/// " (line N)" for a node read from the file; nothing for one made by an override.
std::string lineOf(const YAML::Node& node)
{
  const YAML::Mark mark = node.Mark();
  return mark.is_null() ? std::string() : " (line " + std::to_string(mark.line + 1) + ")";
}

std::string describe(const YAML::Node& node)
{
  switch (node.Type())
  {
    case YAML::NodeType::Scalar:
      return "'" + node.Scalar() + "'";
    case YAML::NodeType::Sequence:
      return "a list of " + std::to_string(node.size());
    case YAML::NodeType::Map:
      return "a map";
    default:
      return "nothing";
  }
}

[[noreturn]] void typeError(const Entry& e, const std::string& expected)
{
  throw ConfigError(e.key, "expected " + expected + ", got " + describe(e.node) + lineOf(e.node));
}

/// Levenshtein distance, for "did you mean" hints.
std::size_t editDistance(const std::string& a, const std::string& b)
{
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i)
  {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j)
    {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

std::string joinNames(const std::vector<std::string>& names)
{
  std::string out;
  for (std::size_t i = 0; i < names.size(); ++i)
    out += (i == 0 ? "" : (i + 1 == names.size() ? " or " : ", ")) + names[i];
  return out;
}

// ------------------------------------------------------------------------------------ values

template <typename T>
const char* expectedName();
template <>
const char* expectedName<double>()
{
  return "a number";
}
template <>
const char* expectedName<int>()
{
  return "an integer";
}
template <>
const char* expectedName<bool>()
{
  return "true or false";
}
template <>
const char* expectedName<std::string>()
{
  return "a string";
}

template <typename T>
T readScalar(const Entry& e)
{
  if (e.node.IsScalar())
  {
    try
    {
      return e.node.as<T>();
    }
    catch (const YAML::BadConversion&)
    {
    }
  }
  typeError(e, expectedName<T>());
}

template <typename T, std::size_t N>
std::array<T, N> readArray(const Entry& e, const std::string& expected)
{
  if (!e.node.IsSequence() || e.node.size() != N) typeError(e, expected);
  std::array<T, N> out;
  for (std::size_t i = 0; i < N; ++i) out[i] = readScalar<T>({e.node[i], indexKey(e.key, i)});
  return out;
}

Vec3d readVec3(const Entry& e)
{
  const auto a = readArray<double, 3>(e, "a 3-vector [x, y, z]");
  return Vec3d(a[0], a[1], a[2]);
}

void readInto(const Entry& e, double& out)
{
  out = readScalar<double>(e);
}
void readInto(const Entry& e, int& out)
{
  out = readScalar<int>(e);
}
void readInto(const Entry& e, bool& out)
{
  out = readScalar<bool>(e);
}
void readInto(const Entry& e, std::string& out)
{
  out = readScalar<std::string>(e);
}
void readInto(const Entry& e, Vec3d& out)
{
  out = readVec3(e);
}

/// Scene names of the mesh offset modes (core names the other enums).
const char* toString(SurfaceOffset offset)
{
  return offset == SurfaceOffset::Auto ? "auto" : "none";
}

/// One of `values`, named as toString() names it (the names live in core, next to the enums).
template <typename E>
E readEnum(const Entry& e, std::initializer_list<E> values)
{
  const std::string name = readScalar<std::string>(e);
  std::vector<std::string> names;
  for (E value : values)
  {
    if (name == toString(value)) return value;
    names.emplace_back(toString(value));
  }
  throw ConfigError(e.key, "unknown value '" + name + "' (expected " + joinNames(names) + ")" + lineOf(e.node));
}

/// Calls f(item) for every item of a list; an absent or empty (null) value is an empty list.
template <typename F>
void forEachItem(const Entry& e, F&& f)
{
  if (e.node.IsNull()) return;
  if (!e.node.IsSequence()) typeError(e, "a list");
  for (std::size_t i = 0; i < e.node.size(); ++i) f(Entry{e.node[i], indexKey(e.key, i)});
}

/// Reads one YAML map strictly. Every key asked for (present or not) becomes known; finish()
/// rejects any other key, naming it. A null value ("solver:" with nothing below) is an empty map.
class MapReader
{
public:
  explicit MapReader(const Entry& e) : entry_(e)
  {
    if (entry_.node.IsNull()) return;
    if (!entry_.node.IsMap()) typeError(entry_, "a map");
    std::set<std::string> seen;
    for (const auto& item : entry_.node)
    {
      if (!item.first.IsScalar()) throw ConfigError(entry_.key, "keys must be plain names" + lineOf(item.first));
      if (!seen.insert(item.first.Scalar()).second)
        throw ConfigError(childKey(entry_.key, item.first.Scalar()), "duplicate key" + lineOf(item.first));
    }
  }

  bool has(const std::string& name)
  {
    known_.insert(name);
    return entry_.node.IsMap() && static_cast<bool>(constNode()[name]);
  }

  std::optional<Entry> get(const std::string& name)
  {
    if (!has(name)) return std::nullopt;
    return Entry{constNode()[name], childKey(entry_.key, name)};
  }

  Entry require(const std::string& name)
  {
    if (auto e = get(name)) return *e;
    throw ConfigError(childKey(entry_.key, name), "missing" + lineOf(entry_.node));
  }

  /// Reads an optional value; leaves `out` (the default) alone if the key is absent.
  template <typename T>
  void read(const std::string& name, T& out)
  {
    if (auto e = get(name)) readInto(*e, out);
  }

  /// Throws for the first key that was never asked for.
  void finish() const
  {
    if (!entry_.node.IsMap()) return;
    for (const auto& item : entry_.node)
    {
      const std::string name = item.first.Scalar();
      if (known_.count(name) == 0)
        throw ConfigError(childKey(entry_.key, name), "unknown key" + hint(name) + lineOf(item.first));
    }
  }

private:
  const YAML::Node& constNode() const  // const access: operator[] must not insert keys
  {
    return entry_.node;
  }

  std::string hint(const std::string& name) const
  {
    std::string best;
    std::size_t best_distance = 3;  // suggest only close matches
    for (const auto& known : known_)
    {
      const std::size_t d = editDistance(name, known);
      if (d < best_distance)
      {
        best = known;
        best_distance = d;
      }
    }
    if (!best.empty()) return " (did you mean '" + best + "'?)";
    std::string names;
    for (const auto& known : known_) names += (names.empty() ? "" : ", ") + known;
    return " (known keys: " + names + ")";
  }

  Entry entry_;
  std::set<std::string> known_;
};

// ------------------------------------------------------------------------------------ sections

/// What reading boundaries needs besides the YAML: where files are, and where notes go.
struct LoadContext
{
  std::string source;        // scene file, for notes
  std::string base_dir;      // relative file names are relative to it
  PackageResolver packages;  // package:// URIs
  double spacing = 0.02;     // m, the scene spacing (read before the boundaries)
  std::size_t max_boundary_particles = 2000000;
  std::vector<std::string>* warnings = nullptr;
};

/// Rethrows an error about a file named `written` in the scene (resolved to `resolved`) under the
/// scene key `key`: "<written> (= <resolved>): <reason>", or the error's own text when it names
/// something inside the file (a URDF link).
[[noreturn]] void fileError(const Entry& at, const std::string& written, const std::string& resolved,
                            const ConfigError& error)
{
  const bool about_file = error.key() == resolved || error.key() == written || error.key().empty();
  const std::string shown = resolved.empty() || resolved == written ? written : written + " (= " + resolved + ")";
  throw ConfigError(at.key,
                    (about_file ? shown + ": " + error.message() : std::string(error.what())) + lineOf(at.node));
}

AxisBox readBox(const Entry& e)
{
  MapReader r(e);
  AxisBox box;
  box.min = readVec3(r.require("min"));
  box.max = readVec3(r.require("max"));
  r.finish();
  return box;
}

TimeStepConfig readTimeStep(const Entry& e)
{
  MapReader r(e);
  TimeStepConfig ts;
  ts.adaptive = r.has("cfl");
  if (ts.adaptive && r.has("fixed")) throw ConfigError(e.key, "give either fixed or cfl, not both" + lineOf(e.node));
  r.read("fixed", ts.fixed);
  r.read("cfl", ts.cfl);
  for (const char* name : {"min", "max"})
    if (r.has(name) && !ts.adaptive)
      throw ConfigError(childKey(e.key, name), "only with time_step.cfl (an adaptive step)");
  r.read("min", ts.min);
  r.read("max", ts.max);
  r.finish();
  return ts;
}

SolverConfig readSolver(const Entry& e)
{
  MapReader r(e);
  SolverConfig s;
  if (auto m = r.get("boundary_pressure"))
    s.boundary_pressure = readEnum(
        *m, {BoundaryPressureMethod::Mirroring, BoundaryPressureMethod::SphExtrapolation, BoundaryPressureMethod::Mls});
  r.read("density_error", s.density_error);
  r.read("divergence_error", s.divergence_error);
  r.read("min_iterations", s.min_iterations);
  r.read("max_iterations", s.max_iterations);
  r.read("min_divergence_iterations", s.min_divergence_iterations);
  r.read("divergence_solve", s.divergence_solve);
  r.read("warm_start", s.warm_start);
  r.read("omega", s.omega);
  r.read("clamp_boundary_pressure", s.clamp_boundary_pressure);
  r.read("limit_boundary_pressure", s.limit_boundary_pressure);
  r.read("mls_fit_radius", s.mls_fit_radius);
  r.read("mls_eigen_tolerance", s.mls_eigen_tolerance);
  if (auto m = r.get("mls_singular"))
    s.mls_singular = readEnum(*m, {MlsSingularMode::Fallback, MlsSingularMode::PseudoInverse});
  r.finish();
  return s;
}

ViscosityConfig readViscosity(const Entry& e)
{
  MapReader r(e);
  ViscosityConfig v;
  if (auto m = r.get("model"))
    v.model = readEnum(*m, {ViscosityModel::None, ViscosityModel::Artificial, ViscosityModel::Xsph});
  r.read("coefficient", v.coefficient);
  r.read("boundary", v.boundary);
  r.finish();
  return v;
}

StabilityConfig readStability(const Entry& e)
{
  MapReader r(e);
  StabilityConfig s;
  r.read("max_density_error", s.max_density_error);
  r.read("max_cfl", s.max_cfl);
  r.finish();
  return s;
}

OutputConfig readOutput(const Entry& e)
{
  MapReader r(e);
  OutputConfig o;
  r.read("frame_interval", o.frame_interval);
  r.finish();
  return o;
}

FluidBlockConfig readFluidBlock(const Entry& e)
{
  MapReader r(e);
  FluidBlockConfig f;
  f.box = readBox(r.require("box"));
  r.read("velocity", f.velocity);
  r.finish();
  return f;
}

SphereShape readSphere(const Entry& e)
{
  MapReader r(e);
  SphereShape s;
  s.center = readVec3(r.require("center"));
  readInto(r.require("radius"), s.radius);
  r.finish();
  return s;
}

CylinderShape readCylinder(const Entry& e)
{
  MapReader r(e);
  CylinderShape c;
  c.center = readVec3(r.require("center"));
  c.axis = readVec3(r.require("axis"));
  readInto(r.require("radius"), c.radius);
  readInto(r.require("length"), c.length);
  r.finish();
  return c;
}

/// A mesh scale: one number, or one per axis; finite and not zero.
Vec3d readScale(const Entry& e)
{
  Vec3d scale = e.node.IsSequence() ? readVec3(e) : Vec3d::Constant(readScalar<double>(e));
  if (!scale.allFinite() || (scale.array() == 0.0).any())
    throw ConfigError(e.key, "must be finite and not zero (a number or [x, y, z])" + lineOf(e.node));
  return scale;
}

/// A boundary mesh: inline, or read from a file.
struct SceneMesh
{
  TriangleMesh mesh;
  bool closed = false;
  std::string file;  // as written; "" for an inline mesh
  std::size_t border_edges = 0;
  std::size_t degenerate_triangles = 0;
};

SceneMesh readMesh(const Entry& e, const LoadContext& ctx)
{
  MapReader r(e);
  SceneMesh out;
  if (auto file = r.get("file"))
  {
    if (r.has("vertices") || r.has("triangles"))
      throw ConfigError(e.key, "give either file or vertices and triangles, not both" + lineOf(e.node));
    Vec3d scale = Vec3d::Ones();
    if (auto sc = r.get("scale")) scale = readScale(*sc);
    r.finish();
    out.file = readScalar<std::string>(*file);
    std::string path;
    try
    {
      path = resolveResource(out.file, ctx.base_dir, ctx.packages);
      MeshFile m = readMeshFile(path, scale);
      out.mesh = std::move(m.mesh);
      out.closed = m.closed;
      out.border_edges = m.border_edges;
      out.degenerate_triangles = m.degenerate_triangles;
    }
    catch (const ConfigError& error)
    {
      fileError(*file, out.file, path, error);
    }
    return out;
  }
  if (auto scale = r.get("scale")) throw ConfigError(scale->key, "only with file" + lineOf(scale->node));
  forEachItem(r.require("vertices"), [&](const Entry& v) { out.mesh.vertices.push_back(readVec3(v)); });
  forEachItem(r.require("triangles"),
              [&](const Entry& t) { out.mesh.triangles.push_back(readArray<int, 3>(t, "a triangle [i, j, k]")); });
  r.finish();
  out.closed = orientOutward(out.mesh);
  buildInsideIndex(out.mesh);
  return out;
}

Pose readPose(const Entry& e)
{
  MapReader r(e);
  Vec3d xyz = Vec3d::Zero();  // m
  Vec3d rpy = Vec3d::Zero();  // rad
  r.read("xyz", xyz);
  r.read("rpy", rpy);
  r.finish();
  return Pose::fromXyzRpy(xyz, rpy);
}

MotionConfig readMotion(const Entry& e)
{
  MapReader r(e);
  MotionConfig m;
  r.read("angular_velocity", m.angular_velocity);
  r.read("about", m.about);
  r.read("linear_velocity", m.linear_velocity);
  r.finish();
  return m;
}

/// Refuses a body whose sampling would exceed the particle budget, naming the scene entry.
void checkBudget(const Entry& e, const BoundaryConfig& b, const LoadContext& ctx)
{
  const double ss = b.sample_spacing > 0.0 ? b.sample_spacing : ctx.spacing;  // m
  if (!(ss > 0.0)) return;                                                    // validate() reports the spacing
  const double estimate = estimateBoundaryParticles(b, ss, ctx.spacing);
  if (!(estimate <= double(ctx.max_boundary_particles)))
    throw ConfigError(
        e.key, "'" + b.name + "' would need about " + std::to_string(static_cast<long long>(std::round(estimate))) +
                   " boundary particles at sample spacing " + std::to_string(ss) +
                   " m, more than max_boundary_particles = " + std::to_string(ctx.max_boundary_particles) +
                   "; use a coarser spacing or sample_spacing, a smaller body, or raise "
                   "max_boundary_particles" +
                   lineOf(e.node));
}

/// urdf: {file, links, joint_positions}: one body per selected link, each with the entry's common
/// keys (`common`: inside, pose of the root link, motion, sample_spacing, external, offset).
std::vector<BoundaryConfig> readUrdf(const Entry& e, const BoundaryConfig& common, double finest_spacing,
                                     const LoadContext& ctx)
{
  MapReader r(e);
  const Entry file = r.require("file");
  const std::string written = readScalar<std::string>(file);
  std::string path;
  UrdfRobot robot;
  try
  {
    path = resolveResource(written, ctx.base_dir, ctx.packages);
    robot = readUrdfFile(path);
  }
  catch (const ConfigError& error)
  {
    fileError(file, written, path, error);
  }
  // Shown in messages as the scene names it.
  const std::string urdf_name = written == path ? written : written + " (= " + path + ")";

  UrdfBoundaryOptions options;
  if (auto links = r.get("links"))
    forEachItem(*links, [&](const Entry& item) {
      const std::string name = readScalar<std::string>(item);
      if (!robot.link(name))
      {
        std::vector<std::string> names;
        for (const auto& l : robot.links) names.push_back(l.name);
        throw ConfigError(item.key, "unknown link '" + name + "' in " + urdf_name + " (links: " + joinNames(names) +
                                        ")" + lineOf(item.node));
      }
      if (std::find(options.links.begin(), options.links.end(), name) != options.links.end())
        throw ConfigError(item.key, "link '" + name + "' is listed twice" + lineOf(item.node));
      options.links.push_back(name);
    });
  if (auto positions = r.get("joint_positions"))
  {
    if (!positions->node.IsMap() && !positions->node.IsNull()) typeError(*positions, "a map {joint: position}");
    MapReader check(*positions);  // rejects duplicate and non-scalar keys
    for (const auto& item : positions->node)
    {
      const Entry value{item.second, childKey(positions->key, item.first.Scalar())};
      const std::string name = item.first.Scalar();
      const UrdfJoint* joint = robot.joint(name);
      if (!joint)
      {
        std::vector<std::string> names;
        for (const auto& j : robot.joints)
          if (j.type != UrdfJointType::Fixed) names.push_back(j.name);
        throw ConfigError(value.key, "unknown joint '" + name + "' in " + urdf_name +
                                         " (movable joints: " + joinNames(names) + ")" + lineOf(item.first));
      }
      if (joint->type != UrdfJointType::Revolute && joint->type != UrdfJointType::Continuous &&
          joint->type != UrdfJointType::Prismatic)
        throw ConfigError(value.key, "joint '" + name + "' in " + urdf_name +
                                         " is not revolute, continuous or prismatic: it has no position to set" +
                                         lineOf(item.first));
      options.joint_positions[name] = readScalar<double>(value);
    }
  }
  r.finish();
  options.root_pose = common.pose;
  options.spacing = finest_spacing;
  options.packages = ctx.packages;
  std::vector<BoundaryConfig> bodies;
  try
  {
    bodies = urdfBoundaries(robot, options, ctx.warnings);
  }
  catch (const ConfigError& error)
  {
    throw ConfigError(e.key, std::string(error.what()) + lineOf(e.node));
  }
  if (bodies.empty())
    throw ConfigError(e.key, urdf_name + " has no link with collision geometry" +
                                 (options.links.empty() ? std::string() : " among the links listed") + lineOf(e.node));
  for (auto& b : bodies)
  {
    b.inside = common.inside;
    b.motion = common.motion;
    b.sample_spacing = common.sample_spacing;
    b.externally_posed = common.externally_posed;
    b.mesh_offset = common.mesh_offset;
  }
  return bodies;
}

/// One entry of `boundaries`: one body, or one per URDF link.
std::vector<BoundaryConfig> readBoundary(const Entry& e, std::size_t index, const LoadContext& ctx)
{
  MapReader r(e);
  // Exactly one shape key.
  std::vector<std::string> shapes;
  for (const char* name : {"box", "sphere", "cylinder", "mesh", "urdf"})
    if (r.has(name)) shapes.emplace_back(name);
  if (shapes.size() != 1)
    throw ConfigError(
        e.key, (shapes.empty() ? std::string("needs a shape: box, sphere, cylinder, mesh or urdf")
                               : "has two shape keys, '" + shapes[0] + "' and '" + shapes[1] + "'; give exactly one") +
                   lineOf(e.node));
  const std::string& shape_name = shapes.front();
  const Entry shape = r.require(shape_name);

  // The keys every shape shares; sample_spacing first, it sets the facet error of URDF primitives.
  BoundaryConfig b;
  b.name = shape_name + std::to_string(index);
  r.read("inside", b.inside);
  if (auto pose = r.get("pose")) b.pose = readPose(*pose);
  if (auto motion = r.get("motion")) b.motion = readMotion(*motion);
  r.read("sample_spacing", b.sample_spacing);
  r.read("external", b.externally_posed);
  bool offset_given = false;
  if (auto offset = r.get("offset"))
  {
    if (shape_name != "mesh" && shape_name != "urdf")
      throw ConfigError(offset->key, "only mesh boundaries (mesh, urdf) have an offset" + lineOf(offset->node));
    b.mesh_offset = readEnum(*offset, {SurfaceOffset::Auto, SurfaceOffset::None});
    offset_given = true;
  }
  if (shape_name == "urdf")
  {
    if (auto name = r.get("name"))
      throw ConfigError(name->key,
                        "a urdf entry's bodies are named after its links; give no name" + lineOf(name->node));
    r.finish();
    const double finest = b.sample_spacing > 0.0 ? std::min(b.sample_spacing, ctx.spacing) : ctx.spacing;
    std::vector<BoundaryConfig> bodies = readUrdf(shape, b, finest, ctx);
    for (const auto& body : bodies) checkBudget(e, body, ctx);
    return bodies;
  }
  r.read("name", b.name);
  r.finish();

  if (shape_name == "box")
  {
    b.type = ShapeType::Box;
    b.box = readBox(shape);
  }
  else if (shape_name == "sphere")
  {
    b.type = ShapeType::Sphere;
    b.sphere = readSphere(shape);
  }
  else if (shape_name == "cylinder")
  {
    b.type = ShapeType::Cylinder;
    b.cylinder = readCylinder(shape);
  }
  else
  {
    SceneMesh mesh = readMesh(shape, ctx);
    b.type = ShapeType::Mesh;
    b.mesh = std::move(mesh.mesh);
    b.mesh_closed = mesh.closed;
    if (ctx.warnings && !mesh.file.empty())
    {
      const std::string what = ctx.source + ": " + e.key + " '" + b.name + "' (" + mesh.file + ")";
      for (auto& note : surfaceNotes(what, mesh.closed || (offset_given && b.mesh_offset == SurfaceOffset::None),
                                     mesh.border_edges, mesh.degenerate_triangles))
        ctx.warnings->push_back(std::move(note));
    }
  }
  checkBudget(e, b, ctx);
  return {b};
}

SceneConfig readScene(const YAML::Node& root, LoadContext& ctx)
{
  MapReader r({root, ""});
  SceneConfig s;
  r.read("spacing", s.spacing);
  if (auto e = r.get("max_boundary_particles"))
  {
    const double n = readScalar<double>(*e);
    if (!(n >= 1.0 && n <= 1.0e12 && n == std::floor(n)))
      throw ConfigError(e->key, "must be a whole number >= 1" + lineOf(e->node));
    s.max_boundary_particles = static_cast<std::size_t>(n);
  }
  ctx.spacing = s.spacing;
  ctx.max_boundary_particles = s.max_boundary_particles;
  ctx.warnings = &s.warnings;
  r.read("rest_density", s.rest_density);
  r.read("gravity", s.gravity);
  if (auto e = r.get("domain")) s.domain = readBox(*e);
  if (auto e = r.get("time_step")) s.time_step = readTimeStep(*e);
  if (auto e = r.get("solver")) s.solver = readSolver(*e);
  if (auto e = r.get("viscosity")) s.viscosity = readViscosity(*e);
  if (auto e = r.get("stability")) s.stability = readStability(*e);
  r.read("duration", s.duration);
  if (auto e = r.get("fluid")) forEachItem(*e, [&](const Entry& item) { s.fluid.push_back(readFluidBlock(item)); });
  if (auto e = r.get("boundaries"))
    forEachItem(*e, [&](const Entry& item) {
      for (auto& b : readBoundary(item, s.boundaries.size(), ctx)) s.boundaries.push_back(std::move(b));
    });
  if (auto e = r.get("output")) s.output = readOutput(*e);
  r.finish();
  return s;
}

// ------------------------------------------------------------------------------------ overrides

/// One --set key.path=value.
struct Override
{
  std::string text;  // as given
  std::string key;   // "boundaries[1].sphere.radius"
  YAML::Node value;
};

/// One step of a key path: a map key, or a list index when `index` is set.
struct PathStep
{
  std::string name;
  std::optional<std::size_t> index;
};

std::vector<PathStep> parseKeyPath(const std::string& key)
{
  std::vector<PathStep> steps;
  std::size_t i = 0;
  const auto malformed = [&]() { return ConfigError(key, "malformed key path in --set (expected e.g. a.b[1].c)"); };
  while (i < key.size())
  {
    const std::size_t end = key.find_first_of(".[]", i);
    const std::string name = key.substr(i, end == std::string::npos ? std::string::npos : end - i);
    if (name.empty()) throw malformed();
    steps.push_back({name, std::nullopt});
    i = end == std::string::npos ? key.size() : end;
    while (i < key.size() && key[i] == '[')
    {
      const std::size_t close = key.find(']', i);
      const std::string digits = key.substr(i + 1, close == std::string::npos ? 0 : close - i - 1);
      if (close == std::string::npos || digits.empty() || digits.find_first_not_of("0123456789") != std::string::npos)
        throw malformed();
      steps.push_back({"", std::stoul(digits)});
      i = close + 1;
    }
    if (i < key.size())
    {
      if (key[i] != '.' || i + 1 == key.size()) throw malformed();
      ++i;
    }
  }
  if (steps.empty()) throw malformed();
  return steps;
}

/// A deep copy built node by node: the copy carries no marks, so messages do not cite the line
/// of the --set value as if it were a line of the scene file.
YAML::Node copyWithoutMarks(const YAML::Node& node)
{
  switch (node.Type())
  {
    case YAML::NodeType::Scalar:
      return YAML::Node(node.Scalar());
    case YAML::NodeType::Sequence:
    {
      YAML::Node out(YAML::NodeType::Sequence);
      for (const auto& item : node) out.push_back(copyWithoutMarks(item));
      return out;
    }
    case YAML::NodeType::Map:
    {
      YAML::Node out(YAML::NodeType::Map);
      for (const auto& item : node) out[copyWithoutMarks(item.first)] = copyWithoutMarks(item.second);
      return out;
    }
    default:
      return YAML::Node(YAML::NodeType::Null);
  }
}

Override parseOverride(const std::string& text)
{
  const std::size_t eq = text.find('=');
  if (eq == std::string::npos || eq == 0) throw ConfigError("", "--set '" + text + "': expected key.path=value");
  Override o{text, text.substr(0, eq), {}};
  try
  {
    o.value = copyWithoutMarks(YAML::Load(text.substr(eq + 1)));
  }
  catch (const YAML::Exception& ex)
  {
    throw ConfigError(o.key, "cannot parse the value of --set " + text + ": " + ex.msg);
  }
  return o;
}

/// Sets o.value at o.key in the tree, creating missing map keys (the conversion then rejects
/// unknown ones, as in the file). List indices must exist.
void applyOverride(YAML::Node& root, const Override& o)
{
  const std::vector<PathStep> steps = parseKeyPath(o.key);
  YAML::Node node = root;  // a handle into the tree; reset() moves it, operator= would assign
  std::string path;
  for (std::size_t i = 0; i < steps.size(); ++i)
  {
    const PathStep& step = steps[i];
    YAML::Node child;
    if (!step.index)
    {
      if (node.IsDefined() && !node.IsMap() && !node.IsNull())  // undefined: a key just created
        throw ConfigError(path, "is " + describe(node) + ", not a map; cannot set " + o.key);
      path = childKey(path, step.name);
      child.reset(node[step.name]);
    }
    else
    {
      if (!node.IsSequence())
        throw ConfigError(path, (node.IsDefined() ? "is " + describe(node) + ", not a list" : "is not in the scene") +
                                    "; cannot set " + o.key);
      path = indexKey(path, *step.index);
      if (*step.index >= node.size())
        throw ConfigError(path, "index out of range (the list has " + std::to_string(node.size()) + " entries)");
      child.reset(node[*step.index]);
    }
    if (i + 1 < steps.size())
    {
      node.reset(child);
      continue;
    }
    child = o.value;
    // A time step is either fixed or adaptive: setting one mode drops the other's keys.
    if (o.key == "time_step.fixed")
      for (const char* name : {"cfl", "min", "max"}) node.remove(name);
    else if (o.key == "time_step.cfl")
      node.remove("fixed");
  }
}

/// " (after --set ...)" if an override touched `key` or a key above or below it.
std::string overrideNote(const std::vector<Override>& applied, const std::string& key)
{
  const auto within = [](const std::string& inner, const std::string& outer) {
    return inner.compare(0, outer.size(), outer) == 0 &&
           (inner.size() == outer.size() || inner[outer.size()] == '.' || inner[outer.size()] == '[');
  };
  for (auto it = applied.rbegin(); it != applied.rend(); ++it)
    if (!key.empty() && (within(key, it->key) || within(it->key, key))) return " (after --set " + it->text + ")";
  return "";
}

YAML::Node parseYaml(const std::string& text)
{
  try
  {
    return YAML::Load(text);
  }
  catch (const YAML::ParserException& ex)
  {
    throw ConfigError("", "YAML syntax error at line " + std::to_string(ex.mark.line + 1) + ", column " +
                              std::to_string(ex.mark.column + 1) + ": " + ex.msg);
  }
}

}  // namespace

SceneConfig parseScene(const std::string& yaml_text, const std::string& source_name,
                       const std::vector<std::string>& overrides, const SceneLoadOptions& options)
{
  std::vector<Override> applied;
  try
  {
    YAML::Node root = parseYaml(yaml_text);
    for (const std::string& text : overrides)
    {
      applied.push_back(parseOverride(text));
      applyOverride(root, applied.back());
    }
    LoadContext ctx;
    ctx.source = source_name;
    ctx.base_dir =
        options.base_dir.empty() ? std::filesystem::path(source_name).parent_path().string() : options.base_dir;
    ctx.packages = options.packages;
    if (!ctx.packages)
    {
      // The package the scene belongs to first (its own meshes resolve without any set-up), then
      // ROS_PACKAGE_PATH.
      const std::string own = enclosingPackageFolder(ctx.base_dir.empty() ? "." : ctx.base_dir);
      ctx.packages = defaultPackageResolver(own.empty() ? std::vector<std::string>{} : std::vector<std::string>{own});
    }
    SceneConfig scene = readScene(root, ctx);
    scene.source = source_name;
    validate(scene);
    return scene;
  }
  catch (const ConfigError& e)
  {
    throw SceneError(source_name, e.key(), e.message() + overrideNote(applied, e.key()));
  }
  catch (const YAML::Exception& e)
  {
    throw SceneError(source_name, "", e.what());
  }
}

SceneConfig loadScene(const std::string& path, const std::vector<std::string>& overrides,
                      const SceneLoadOptions& options)
{
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw SceneError(path, "", "no such file");
  if (std::filesystem::is_directory(path, ec)) throw SceneError(path, "", "is a directory, not a scene file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw SceneError(path, "", std::string("cannot open: ") + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw SceneError(path, "", std::string("cannot read: ") + std::strerror(errno));
  return parseScene(text.str(), path, overrides, options);
}

}  // namespace io
}  // namespace fluid_sim
