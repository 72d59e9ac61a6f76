// The scene schema: which keys a scene file has, their defaults, and how they become a
// SceneConfig (boundary meshes and URDFs read on the way). The strict reading itself is
// yaml_reader.h; --set overrides are scene_overrides.h.
#include "fluid_sim/io/scene_loader.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <initializer_list>
#include <limits>
#include <sstream>
#include <unordered_map>
#include <vector>

#include "fluid_sim/core/boundary_sampling.h"
#include "fluid_sim/core/cell_key.h"
#include "fluid_sim/core/kernel.h"
#include "fluid_sim/core/mesh_inside_index.h"
#include "fluid_sim/io/file_util.h"
#include "fluid_sim/io/mesh_loader.h"
#include "fluid_sim/io/mesh_topology.h"
#include "fluid_sim/io/message_names.h"
#include "fluid_sim/io/ply_reader.h"
#include "fluid_sim/io/scene_overrides.h"
#include "fluid_sim/io/urdf_loader.h"
#include "fluid_sim/io/yaml_reader.h"

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
using namespace yaml;  // Entry, MapReader, readScalar, ...: the strict reader

/// Scene names of the mesh offset modes (core names the other enums).
const char* toString(SurfaceOffset offset)
{
  return offset == SurfaceOffset::Auto ? "auto" : "none";
}

/// One of `values`, by its scene name: toString() of the value (in core, next to the enums).
template <typename E>
E readNamed(const Entry& e, std::initializer_list<E> values)
{
  return readEnum(e, values, [](E value) { return toString(value); });
}

// ------------------------------------------------------------------------------------ the schema

/// What reading boundaries needs besides the YAML: where files are, and where notes go.
struct LoadContext
{
  std::string source;                            // scene file, for notes
  std::string base_dir;                          // relative file names are relative to it
  PackageResolver packages;                      // package:// URIs
  double spacing = 0.02;                         // m, the scene spacing (read before the boundaries)
  std::size_t max_boundary_particles = 2000000;  // per body, the scene's budget
  std::vector<std::string>* warnings = nullptr;  // the scene's notes (SceneConfig::warnings)
};

/// Rethrows an error about a file named `written` in the scene (resolved to `resolved`) under the
/// scene key of `at`: "<written> (= <resolved>): <reason>", or the error's own text when it names
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
    s.boundary_pressure = readNamed(*m, {BoundaryPressureMethod::Mirroring, BoundaryPressureMethod::MirroringEq2,
                                         BoundaryPressureMethod::SphExtrapolation, BoundaryPressureMethod::Mls});
  r.read("density_error", s.density_error);
  r.read("divergence_error", s.divergence_error);
  r.read("min_iterations", s.min_iterations);
  r.read("max_iterations", s.max_iterations);
  r.read("min_divergence_iterations", s.min_divergence_iterations);
  r.read("divergence_solve", s.divergence_solve);
  r.read("warm_start", s.warm_start);
  r.read("warm_start_divergence", s.warm_start_divergence);
  if (auto m = r.get("cold_start")) s.cold_start = readNamed(*m, {ColdStart::Zero, ColdStart::Jacobi});
  if (auto m = r.get("warm_start_guess"))
    s.warm_start_guess = readNamed(*m, {WarmStartGuess::Previous, WarmStartGuess::Damped});
  r.read("omega", s.omega);
  if (auto m = r.get("sweep")) s.sweep = readNamed(*m, {SweepOrder::Jacobi, SweepOrder::GaussSeidel});
  r.read("chebyshev_rho", s.chebyshev_rho);
  r.read("wall_guard", s.wall_guard);
  r.read("chebyshev_delay", s.chebyshev_delay);
  r.read("clamp_boundary_pressure", s.clamp_boundary_pressure);
  r.read("limit_boundary_pressure", s.limit_boundary_pressure);
  r.read("diagonal_feedback", s.diagonal_feedback);
  r.read("wall_velocity_in_density_rate", s.wall_velocity_in_density_rate);
  r.read("mls_fit_radius", s.mls_fit_radius);
  r.read("mls_eigen_tolerance", s.mls_eigen_tolerance);
  if (auto m = r.get("mls_singular"))
    s.mls_singular =
        readNamed(*m, {MlsSingularMode::Fallback, MlsSingularMode::PseudoInverse, MlsSingularMode::Regularized});
  r.finish();
  return s;
}

ViscosityConfig readViscosity(const Entry& e)
{
  MapReader r(e);
  ViscosityConfig v;
  const std::optional<Entry> model = r.get("model");
  if (model) v.model = readNamed(*model, {ViscosityModel::None, ViscosityModel::Artificial, ViscosityModel::Xsph});
  r.read("coefficient", v.coefficient);
  r.read("boundary", v.boundary);
  r.finish();
  // Coefficients without a model were ignored without a word (the default model is none); an
  // explicit `model: none` keeps them, so that a scene's viscosity can be switched off with
  // --set viscosity.model=none.
  if (!model)
    for (const char* key : {"coefficient", "boundary"})
      if (auto given = r.get(key))
        if (readScalar<double>(*given) != 0.0)
          throw ConfigError(given->key,
                            "has no effect without viscosity.model (the default is none): give model: "
                            "xsph or artificial" +
                                lineOf(given->node));
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

/// `fill`: the trimming and relaxation of the box blocks' lattices before t = 0.
FillConfig readFill(const Entry& e)
{
  MapReader r(e);
  FillConfig f;
  r.read("trim", f.trim);
  r.read("relax", f.relax);
  r.read("relax_tolerance", f.relax_tolerance);
  r.read("relax_max_steps", f.relax_max_steps);
  r.finish();
  return f;
}

OutputConfig readOutput(const Entry& e)
{
  MapReader r(e);
  OutputConfig o;
  r.read("frame_interval", o.frame_interval);
  r.finish();
  return o;
}

/// How a saved state's particles sit against the scene's spacing, from up to about 1,000 of them
/// spread through the list.
struct Packing
{
  double median_nearest = 0.0;  // m, median distance to the nearest neighbour (+inf: none within 2 s)
  double densest = 0.0;         // the largest s^3 sum_j W(x_i - x_j) (Eq. A1 over rho0): 1 at rest density
};

Packing measurePacking(const std::vector<Vec3d>& x, double spacing)
{
  const double cell = 2.0 * spacing;  // m; the 27 cells around a particle reach at least this far
  std::unordered_map<CellKey, std::vector<std::size_t>, CellKeyHash> grid;
  for (std::size_t i = 0; i < x.size(); ++i) grid[cellKeyOf(x[i], cell)].push_back(i);
  const CubicKernel kernel(Real(2.0 * spacing));  // the scene's kernel (Eq. A18)
  const double s3 = spacing * spacing * spacing;  // m^3
  std::vector<double> nearest;
  Packing out;
  const std::size_t stride = std::max<std::size_t>(1, x.size() / 1000);
  for (std::size_t i = 0; i < x.size(); i += stride)
  {
    const CellKey key = cellKeyOf(x[i], cell);
    double best2 = std::numeric_limits<double>::infinity();  // m^2
    double sum = double(kernel.W0());                        // 1/m^3
    for (long long dz = -1; dz <= 1; ++dz)
      for (long long dy = -1; dy <= 1; ++dy)
        for (long long dx = -1; dx <= 1; ++dx)
        {
          const auto it = grid.find({key.x + dx, key.y + dy, key.z + dz});
          if (it == grid.end()) continue;
          for (std::size_t j : it->second)
            if (j != i)
            {
              const double d2 = (x[j] - x[i]).squaredNorm();
              best2 = std::min(best2, d2);
              sum += double(kernel.W(Real(std::sqrt(d2))));
            }
        }
    nearest.push_back(best2 <= cell * cell ? std::sqrt(best2) : std::numeric_limits<double>::infinity());
    out.densest = std::max(out.densest, sum * s3);
  }
  std::nth_element(nearest.begin(), nearest.begin() + nearest.size() / 2, nearest.end());
  out.median_nearest = nearest[nearest.size() / 2];
  return out;
}

/// particles: {file: FILE}: the particles of a PLY frame the runner wrote (positions and
/// velocities; pressure and density are not used), FILE resolved like a mesh file.
ExplicitParticles readParticles(const Entry& e, const LoadContext& ctx)
{
  MapReader r(e);
  const std::optional<Entry> given = r.get("file");
  r.finish();  // a misspelt key first, with the key it may mean
  const Entry file = given ? *given : r.require("file");
  const std::string written = readScalar<std::string>(file);
  std::string path;
  PlyFrame frame;
  try
  {
    path = resolveResource(written, ctx.base_dir, ctx.packages);
    frame = readPlyFrame(path);
  }
  catch (const ConfigError& error)
  {
    fileError(file, written, path, error);
  }
  // The mass of a particle is rest_density * spacing^3 whatever the file: a state saved at
  // another spacing would start compressed or expanded by the cube of the ratio. The file does
  // not store its spacing. Compressed is what blows up (a frame saved at 3 cm and started at
  // 3.5 cm: 131 m/s in the first step; at 4.5 cm a density error of 1e7), and the densest
  // particle's kernel sum shows it: (3.5 / 3)^3 = 1.59 for that start (3.2 cm: 1.22, also a
  // blow-up), 1.000-1.014 in a dam break's frames at their own spacing; it is warned about above
  // 1.1 (a spacing 3 % too large). Expanded only spreads and falls; median
  // nearest distances at the right spacing are 1.0 on the lattice, 0.97 spacing in water settled
  // for 1 s (hydrostatic_tank), 0.77-0.82 in a dam break's flow, so outside [0.55, 1.4] spacings
  // the file is obviously another spacing's.
  if (ctx.warnings && !frame.positions.empty() && ctx.spacing > 0.0)
  {
    const Packing packing = measurePacking(frame.positions, ctx.spacing);
    const double d = packing.median_nearest;  // m
    if (packing.densest > 1.1 && d >= 0.55 * ctx.spacing)
    {
      std::ostringstream note;
      note << ctx.source << ": " << e.key << " (" << written << "): the densest particles sit at " << packing.densest
           << " times rest density at the scene's spacing of " << ctx.spacing
           << " m (as if saved at a spacing of about " << ctx.spacing / std::cbrt(packing.densest)
           << " m); each particle gets the mass rest_density * spacing^3, so the water starts compressed and will "
              "burst apart in the first step: use the spacing it was saved with";
      ctx.warnings->push_back(note.str());
    }
    else if (packing.densest < 0.85 && d >= 0.55 * ctx.spacing && d <= 1.4 * ctx.spacing)
    {
      // Expanded: even the densest particle, deep in the water, is well under rest density (a
      // 2 cm frame started at 1.5 cm: 0.42, 42 % of the water's mass; its median nearest distance,
      // 1.31 spacings, passed the test below). Beyond 1.4 spacings the kernel barely reaches a
      // neighbour and the sum says nothing of the spacing: the nearest distances below speak.
      std::ostringstream note;
      note << ctx.source << ": " << e.key << " (" << written << "): the densest particles sit at only "
           << packing.densest << " times rest density at the scene's spacing of " << ctx.spacing
           << " m (as if saved at a spacing of about " << ctx.spacing / std::cbrt(packing.densest)
           << " m); each particle gets the mass rest_density * spacing^3, so the water starts with that fraction "
              "of its mass and collapses: use the spacing it was saved with";
      ctx.warnings->push_back(note.str());
    }
    else if (!(d >= 0.55 * ctx.spacing && d <= 1.4 * ctx.spacing))
    {
      std::ostringstream note;
      note << ctx.source << ": " << e.key << " (" << written << "): the particles lie ";
      if (std::isfinite(d))
        note << "about " << d << " m";
      else
        note << "more than " << 2.0 * ctx.spacing << " m";
      note << " from their nearest neighbours (median), the scene's spacing is " << ctx.spacing
           << " m; each particle gets the mass rest_density * spacing^3, so a state saved with another spacing "
              "starts compressed or expanded";
      ctx.warnings->push_back(note.str());
    }
  }
  return {std::move(frame.positions), std::move(frame.velocities)};
}

/// One entry of `fluid`: a box on the lattice (with a velocity), or the particles of a frame.
FluidBlockConfig readFluidBlock(const Entry& e, const LoadContext& ctx)
{
  MapReader r(e);
  FluidBlockConfig f;
  const bool box = r.has("box"), particles = r.has("particles");
  if (box == particles)
    throw ConfigError(e.key,
                      (box ? "give either box or particles, not both" : "needs box or particles") + lineOf(e.node));
  if (particles)
  {
    if (auto velocity = r.get("velocity"))
      throw ConfigError(velocity->key, "only with box (particles carry their own velocities)" + lineOf(velocity->node));
    r.finish();  // a misspelt key is reported before a large file is read
    f.particles = readParticles(r.require("particles"), ctx);
    return f;
  }
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
  checkValue(e, scale.allFinite() && !(scale.array() == 0.0).any(),
             "must be finite and not zero (a number or [x, y, z])");
  return scale;
}

/// A boundary mesh: inline, or read from a file.
struct SceneMesh
{
  TriangleMesh mesh;
  bool closed = false;
  std::string file;                      // as written; "" for an inline mesh
  std::size_t border_edges = 0;          // MeshFile::border_edges, or the inline mesh's
  std::size_t degenerate_triangles = 0;  // MeshFile::degenerate_triangles (a file only)
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
  // Checked here, with their lines, rather than left to validate(): the surface's orientation and
  // the particle budget (checkBudget) use the mesh before validate() runs.
  forEachItem(r.require("vertices"), [&](const Entry& v) {
    const Vec3d p = readVec3(v);
    checkValue(v, p.allFinite(), "must be finite");
    out.mesh.vertices.push_back(p);
  });
  const Entry triangles = r.require("triangles");
  forEachItem(triangles, [&](const Entry& t) {
    const auto triangle = readArray<int, 3>(t, "a triangle [i, j, k]");
    for (int k : triangle)
      checkValue(t, k >= 0 && std::size_t(k) < out.mesh.vertices.size(),
                 "vertex index " + std::to_string(k) + " out of range (the mesh has " +
                     std::to_string(out.mesh.vertices.size()) + " vertices, numbered from 0)");
    out.mesh.triangles.push_back(triangle);
  });
  r.finish();
  out.closed = orientOutward(out.mesh);
  out.border_edges = borderEdges(out.mesh);
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
  // A NaN or infinite angle makes the whole rotation NaN (the body vanishes).
  const auto requireFinite = [&](const char* name, const Vec3d& v) {
    if (v.allFinite()) return;
    std::ostringstream os;
    os << "must be finite, got [" << v.x() << ", " << v.y() << ", " << v.z() << "]";
    throw ConfigError(childKey(e.key, name), os.str() + lineOf(e.node));
  };
  requireFinite("xyz", xyz);
  requireFinite("rpy", rpy);
  return Pose::fromXyzRpy(xyz, rpy);
}

MotionConfig readMotion(const Entry& e)
{
  MapReader r(e);
  MotionConfig m;
  r.read("angular_velocity", m.angular_velocity);
  r.read("about", m.about);
  r.read("linear_velocity", m.linear_velocity);
  r.read("start", m.start);
  r.read("ramp", m.ramp);
  r.read("stop", m.stop);
  r.finish();
  return m;
}

/// `dynamic: {density | mass, inertia, center_of_mass, linear_velocity, angular_velocity}`: a free
/// body. Only types and lengths are checked here; which of density and mass, and whether the
/// numbers are physical, is validate()'s (scene_config.cpp, validateDynamic).
DynamicConfig readDynamic(const Entry& e)
{
  MapReader r(e);
  DynamicConfig d;
  d.enabled = true;
  r.read("density", d.density);         // kg/m^3
  r.read("mass", d.mass);               // kg
  if (auto inertia = r.get("inertia"))  // kg m^2, about the centre of mass, body axes
    d.inertia = readArray<double, 6>(*inertia, "6 numbers [ixx, iyy, izz, ixy, ixz, iyz]");
  if (auto com = r.get("center_of_mass")) d.center_of_mass = readVec3(*com);  // m, body frame
  r.read("linear_velocity", d.linear_velocity);                               // m/s, world
  r.read("angular_velocity", d.angular_velocity);                             // rad/s, world
  r.finish();
  return d;
}

/// `contacts: {friction, model, rolling_resistance}`.
ContactConfig readContacts(const Entry& e)
{
  MapReader r(e);
  ContactConfig c;
  r.read("friction", c.friction);
  r.read("rolling_resistance", c.rolling_resistance);
  if (auto m = r.get("model")) c.model = readNamed(*m, {ContactModel::Bullet, ContactModel::Particles});
  r.finish();
  return c;
}

/// Refuses a body whose sampling would exceed the particle budget, naming the scene entry, and
/// for a mesh its size (a CAD export in millimetres read as metres is the usual cause) and
/// `about` (a URDF link's file and meshes).
void checkBudget(const Entry& e, const BoundaryConfig& b, const LoadContext& ctx, const std::string& about = "")
{
  const double ss = sampleSpacing(b, ctx.spacing);  // m
  if (!(ss > 0.0)) return;                          // validate() reports the spacing
  const double estimate = estimateBoundaryParticles(b, ss, ctx.spacing);
  if (estimate <= double(ctx.max_boundary_particles)) return;
  std::string size;
  if (b.type == ShapeType::Mesh && !b.mesh.vertices.empty())
  {
    const AxisBox bounds = boundsOf(b.mesh.vertices);
    const Vec3d extent = bounds.max - bounds.min;
    size = " (its mesh spans " + numberText(extent.x()) + " x " + numberText(extent.y()) + " x " +
           numberText(extent.z()) + " m" + about + ")";
  }
  else if (!about.empty())
    size = " (" + about.substr(2) + ")";
  throw ConfigError(e.key, "'" + b.name + "'" + size + " would need about " + estimateText(estimate) +
                               " boundary particles at sample spacing " + std::to_string(ss) +
                               " m, more than max_boundary_particles = " + std::to_string(ctx.max_boundary_particles) +
                               "; use a coarser spacing or sample_spacing, a smaller body (a mesh in millimetres "
                               "needs scale 0.001), or raise max_boundary_particles" +
                               lineOf(e.node));
}

/// One entry of `regions`: {name, box: {min, max}, pose: {xyz, rpy}}, {name, sphere: {center,
/// radius}} or {name, body: NAME}. A name is required: it is the region's topic and its rows'
/// label.
RegionConfig readRegion(const Entry& e)
{
  MapReader r(e);
  const std::optional<Entry> name = r.get("name"), pose = r.get("pose");
  std::vector<Entry> shapes;
  for (const char* key : {"box", "sphere", "body"})
    if (auto shape = r.get(key)) shapes.push_back(*shape);
  r.finish();  // a misspelt key first, with the key it may mean
  const auto shapeName = [](const Entry& shape) { return shape.key.substr(shape.key.rfind('.') + 1); };
  if (shapes.size() != 1)
    throw ConfigError(e.key, (shapes.empty() ? std::string("needs a shape: box, sphere or body")
                                             : "has two shapes, '" + shapeName(shapes[0]) + "' and '" +
                                                   shapeName(shapes[1]) + "'; give exactly one") +
                                 lineOf(e.node));
  RegionConfig region;
  readInto(name ? *name : r.require("name"), region.name);
  const Entry& shape = shapes.front();
  const std::string shape_name = shapeName(shape);
  if (pose && shape_name != "box")
  {
    // Sinks are read here too: the message says which list the entry is in.
    const bool sink = e.key.rfind("sinks", 0) == 0;
    throw ConfigError(pose->key, std::string("only a box ") + (sink ? "sink" : "region") +
                                     " has a pose (a sphere is placed by its center" +
                                     (sink ? ")" : ", a body region follows its body)") + lineOf(pose->node));
  }
  if (shape_name == "box")
  {
    region.shape = RegionShape::Box;
    region.box = readBox(shape);
    if (pose) region.pose = readPose(*pose);
  }
  else if (shape_name == "sphere")
  {
    region.shape = RegionShape::Sphere;
    region.sphere = readSphere(shape);
  }
  else
  {
    region.shape = RegionShape::Body;
    readInto(shape, region.body);
  }
  return region;
}

/// One entry of `probes`: {name, position: [x, y, z]}.
ProbeConfig readProbe(const Entry& e)
{
  MapReader r(e);
  const std::optional<Entry> name = r.get("name"), position = r.get("position");
  r.finish();
  ProbeConfig probe;
  readInto(name ? *name : r.require("name"), probe.name);
  probe.position = readVec3(position ? *position : r.require("position"));
  return probe;
}

/// A particle budget (max_fluid_particles, max_boundary_particles, an emitter's max_particles): a
/// whole number in [1, 1e12] (YAML may write it as 2.0e6).
std::size_t readParticleCount(const Entry& e)
{
  const double n = readScalar<double>(e);
  checkValue(e, n >= 1.0 && n <= 1.0e12 && n == std::floor(n), "must be a whole number >= 1");
  return static_cast<std::size_t>(n);
}

/// One entry of `emitters`: {name, circle: {radius} | rectangle: {size: [w, h]}, pose: {xyz,
/// rpy} (or pose: {xyz} with direction: [x, y, z]), speed | flow_rate, start, duration, body,
/// max_particles}.
EmitterConfig readEmitter(const Entry& e)
{
  MapReader r(e);
  const std::optional<Entry> name = r.get("name"), circle = r.get("circle"), rectangle = r.get("rectangle"),
                             pose = r.get("pose"), direction = r.get("direction"), body = r.get("body"),
                             max_particles = r.get("max_particles"), frame = r.get("frame");
  EmitterConfig em;
  // 0 means "not given" in EmitterConfig (the other follows from the nozzle); a 0 written in the
  // scene is a value out of range, named as a negative one is (it read "needs a speed or a
  // flow_rate").
  for (const char* key : {"speed", "flow_rate"})
    if (auto v = r.get(key))
    {
      double& out = std::string(key) == "speed" ? em.speed : em.flow_rate;
      readInto(*v, out);
      if (out == 0.0) throw ConfigError(v->key, "must be > 0, got 0" + lineOf(v->node));
    }
  r.read("start", em.start);
  r.read("duration", em.duration);
  r.finish();
  readInto(name ? *name : r.require("name"), em.name);
  if (bool(circle) == bool(rectangle))
    throw ConfigError(e.key, std::string(circle ? "has two nozzle shapes, 'circle' and 'rectangle'; give one"
                                                : "needs a nozzle shape: circle {radius} or rectangle {size: [w, h]}") +
                                 lineOf(e.node));
  if (circle)
  {
    MapReader c(*circle);
    em.shape = NozzleShape::Circle;
    readInto(c.require("radius"), em.radius);
    c.finish();
  }
  else
  {
    MapReader c(*rectangle);
    em.shape = NozzleShape::Rectangle;
    const Entry size = c.require("size");
    c.finish();
    const std::array<double, 2> wh = readArray<double, 2>(size, "a list [width, height] (m)");
    em.size = Eigen::Vector2d(wh[0], wh[1]);
  }
  if (pose) em.pose = readPose(*pose);
  if (direction)
  {
    // The nozzle's +z axis along the direction (the shortest rotation from +z); it replaces rpy.
    if (pose && MapReader(*pose).has("rpy"))
      throw ConfigError(direction->key, "give either pose.rpy or direction, not both" + lineOf(direction->node));
    const Vec3d d = readVec3(*direction);
    checkValue(*direction, d.allFinite() && d.norm() > 0.0, "must be a finite, non-zero vector");
    em.pose.rotation = Eigen::Quaterniond::FromTwoVectors(Vec3d::UnitZ(), d.normalized());
  }
  if (body) readInto(*body, em.body);
  if (frame)
  {
    readInto(*frame, em.frame);
    checkValue(*frame, !em.frame.empty(), "must name a tf frame");
    em.externally_posed = true;
  }
  if (max_particles) em.max_particles = readParticleCount(*max_particles);
  return em;
}

/// `spill: {below: Z}`.
SpillConfig readSpill(const Entry& e)
{
  MapReader r(e);
  const std::optional<Entry> below = r.get("below");
  r.finish();
  SpillConfig spill;
  spill.enabled = true;
  readInto(below ? *below : r.require("below"), spill.below);
  return spill;
}

/// urdf: {file, links, thin_links, joint_positions, free_links}: one body per selected link, each
/// with the entry's common keys (`common`: inside, pose of the root link, motion, sample_spacing,
/// external, offset, which thin_links overrides with none for its links); the links named in
/// free_links are free bodies (their `dynamic`). `boundary` is the
/// whole `boundaries[i]` entry, which the particle budget's message names.
std::vector<BoundaryConfig> readUrdf(const Entry& e, const BoundaryConfig& common, double finest_spacing,
                                     const LoadContext& ctx, const Entry& boundary)
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
  // A list of the URDF's link names, each once: `links`, and `thin_links` (links whose surface is
  // a thin shell meant as one: offset none for them alone; whether each has a body in this entry
  // is known once the bodies are built, below).
  const auto readLinkNames = [&](const Entry& list, std::vector<std::string>& names, std::vector<Entry>* items) {
    forEachItem(list, [&](const Entry& item) {
      const std::string name = readScalar<std::string>(item);
      if (!robot.link(name))
      {
        std::vector<std::string> all;
        for (const auto& l : robot.links) all.push_back(l.name);
        throw ConfigError(item.key, "unknown link '" + name + "' in " + urdf_name +
                                        " (links: " + joinNames(all, " or ") + ")" + lineOf(item.node));
      }
      if (std::find(names.begin(), names.end(), name) != names.end())
        throw ConfigError(item.key, "link '" + name + "' is listed twice" + lineOf(item.node));
      names.push_back(name);
      if (items) items->push_back(item);
    });
  };
  if (auto links = r.get("links")) readLinkNames(*links, options.links, nullptr);
  std::vector<Entry> thin_items;
  if (auto thin = r.get("thin_links")) readLinkNames(*thin, options.thin_links, &thin_items);
  if (auto positions = r.get("joint_positions"))
  {
    if (!positions->node.IsMap() && !positions->node.IsNull()) typeError(*positions, "a map {joint: position}");
    MapReader keys(*positions);  // rejects duplicate and non-scalar keys
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
                                         " (movable joints: " + joinNames(names, " or ") + ")" + lineOf(item.first));
      }
      if (joint->type != UrdfJointType::Revolute && joint->type != UrdfJointType::Continuous &&
          joint->type != UrdfJointType::Prismatic)
        throw ConfigError(value.key, "joint '" + name + "' in " + urdf_name +
                                         " is not revolute, continuous or prismatic: it has no position to set" +
                                         lineOf(item.first));
      options.joint_positions[name] = readScalar<double>(value);
    }
  }
  // free_links: {link: {density | mass, ...}}, each value read as a boundary's `dynamic`. Whether
  // the link has a body in this entry is known only once the bodies are built (below).
  struct FreeLink
  {
    std::string name;
    Entry at;  // the link's key, for messages (its line)
    DynamicConfig dynamic;
  };
  std::vector<FreeLink> free_links;
  if (auto free = r.get("free_links"))
  {
    if (!free->node.IsMap() && !free->node.IsNull()) typeError(*free, "a map {link: {density | mass, ...}}");
    MapReader keys(*free);  // rejects duplicate and non-scalar keys
    for (const auto& item : free->node)
    {
      const std::string name = item.first.Scalar();
      const Entry value{item.second, childKey(free->key, name)};
      if (!robot.link(name))
      {
        std::vector<std::string> names;
        for (const auto& l : robot.links) names.push_back(l.name);
        throw ConfigError(value.key, "unknown link '" + name + "' in " + urdf_name +
                                         " (links: " + joinNames(names, " or ") + ")" + lineOf(item.first));
      }
      free_links.push_back({name, {item.first, value.key}, readDynamic(value)});
    }
  }
  r.finish();
  options.root_pose = common.pose;
  options.thin_shells_meant = common.mesh_offset == SurfaceOffset::None;  // the default is auto
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
    if (std::find(options.thin_links.begin(), options.thin_links.end(), b.name) == options.thin_links.end())
      b.mesh_offset = common.mesh_offset;  // a thin link's is None (urdfBoundaries)
  }
  // The body of a link that thin_links or free_links names (`at`: its key), which must be one of
  // this entry's.
  const auto bodyOf = [&](const std::string& name, const Entry& at) {
    const auto body =
        std::find_if(bodies.begin(), bodies.end(), [&](const BoundaryConfig& b) { return b.name == name; });
    if (body != bodies.end()) return body;
    std::vector<std::string> names;
    for (const auto& b : bodies) names.push_back(b.name);
    throw ConfigError(at.key, "link '" + name + "' in " + urdf_name +
                                  " is not one of this entry's bodies (not in links, or without collision geometry; "
                                  "bodies: " +
                                  joinNames(names, " or ") + ")" + lineOf(at.node));
  };
  for (const Entry& item : thin_items) bodyOf(readScalar<std::string>(item), item);
  for (const FreeLink& link : free_links)
  {
    const auto body = bodyOf(link.name, link.at);
    body->dynamic = link.dynamic;
    body->dynamic_key = link.at.key;
  }
  for (const BoundaryConfig& body : bodies)
  {
    // Which of the link's collision elements make it so large: their meshes and scales.
    const UrdfLink* link = robot.link(body.name);
    std::string meshes;
    if (link)
      for (const UrdfCollision& c : link->collisions)
        if (c.type == UrdfCollision::Type::Mesh)
          meshes += std::string(meshes.empty() ? "; meshes " : ", ") + c.filename +
                    (c.scale == Vec3d::Ones() ? std::string()
                                              : " at scale " + numberText(c.scale.x()) + " " + numberText(c.scale.y()) +
                                                    " " + numberText(c.scale.z()));
    checkBudget(boundary, body, ctx,
                "; link '" + body.name + "' of " + urdf_name +
                    (link && link->line > 0 ? " (URDF line " + std::to_string(link->line) + ")" : std::string()) +
                    meshes);
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
  if (auto ss = r.get("sample_spacing"))
  {
    if (ss->node.IsScalar() && ss->node.Scalar() == "auto")
      b.sample_spacing = kAutoSampleSpacing;
    else
    {
      readInto(*ss, b.sample_spacing);
      // A negative number would read as auto's marker: refuse it here, with the file's line.
      if (!(b.sample_spacing >= 0.0))
        throw ConfigError(ss->key, "must be >= 0 or auto, got " + std::to_string(b.sample_spacing) + lineOf(ss->node));
    }
  }
  r.read("external", b.externally_posed);
  bool offset_given = false;
  if (auto offset = r.get("offset"))
  {
    if (shape_name != "mesh" && shape_name != "urdf")
      throw ConfigError(offset->key, "only mesh boundaries (mesh, urdf) have an offset" + lineOf(offset->node));
    b.mesh_offset = readNamed(*offset, {SurfaceOffset::Auto, SurfaceOffset::None});
    offset_given = true;
  }
  if (shape_name == "urdf")
  {
    if (auto name = r.get("name"))
      throw ConfigError(name->key,
                        "a urdf entry's bodies are named after its links; give no name" + lineOf(name->node));
    if (auto dynamic = r.get("dynamic"))
      throw ConfigError(dynamic->key,
                        "a urdf entry's links are made free one by one: give urdf.free_links: {LINK: {density: ...}}" +
                            lineOf(dynamic->node));
    r.finish();
    // The links' motion is not known here (external in the node): facets as fine as the finest
    // sampling any of them may get.
    const double finest = b.sample_spacing > 0.0                   ? std::min(b.sample_spacing, ctx.spacing)
                          : b.sample_spacing == kAutoSampleSpacing ? 0.5 * ctx.spacing
                                                                   : ctx.spacing;
    return readUrdf(shape, b, finest, ctx, e);
  }
  r.read("name", b.name);
  if (auto dynamic = r.get("dynamic")) b.dynamic = readDynamic(*dynamic);
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
    if (ctx.warnings)
    {
      // Inline meshes too: an open one used as a solid (offset auto) was not warned about.
      const std::string what =
          ctx.source + ": " + e.key + " '" + b.name + "' (" + (mesh.file.empty() ? "inline mesh" : mesh.file) + ")";
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
  if (auto e = r.get("max_boundary_particles")) s.max_boundary_particles = readParticleCount(*e);
  if (auto e = r.get("max_fluid_particles")) s.max_fluid_particles = readParticleCount(*e);
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
  if (auto e = r.get("fluid"))
    forEachItem(*e, [&](const Entry& item) { s.fluid.push_back(readFluidBlock(item, ctx)); });
  if (auto e = r.get("fill")) s.fill = readFill(*e);
  if (auto e = r.get("boundaries"))
    forEachItem(*e, [&](const Entry& item) {
      for (auto& b : readBoundary(item, s.boundaries.size(), ctx))
      {
        b.key = item.key;  // messages name the scene's entry, not the body's index among a URDF's links
        // An open surface has no inside: the fill keeps no water for it and the flag changed
        // nothing, silently (a round open cup marked inside: true ran as without it).
        if (b.type == ShapeType::Mesh && b.inside && !b.mesh_closed)
          s.warnings.push_back(item.key + " '" + b.name +
                               "': inside: true on an open mesh does nothing (an open surface has no inside to keep "
                               "water in; its walls hold water as any thin shell's do): close the mesh to make it "
                               "a container");
        s.boundaries.push_back(std::move(b));
      }
    });
  if (auto e = r.get("output")) s.output = readOutput(*e);
  if (auto e = r.get("regions")) forEachItem(*e, [&](const Entry& item) { s.regions.push_back(readRegion(item)); });
  if (auto e = r.get("probes")) forEachItem(*e, [&](const Entry& item) { s.probes.push_back(readProbe(item)); });
  if (auto e = r.get("spill")) s.spill = readSpill(*e);
  if (auto e = r.get("contacts")) s.contacts = readContacts(*e);
  // A sink is read as a region (name, box with pose, or sphere); validate() refuses a body one.
  if (auto e = r.get("sinks")) forEachItem(*e, [&](const Entry& item) { s.sinks.push_back(readRegion(item)); });
  if (auto e = r.get("emitters")) forEachItem(*e, [&](const Entry& item) { s.emitters.push_back(readEmitter(item)); });
  r.finish();
  // Single-term mirroring's wall pushes a particle with its own pressure term alone, so the water
  // next to it sits closer to the wall particles' plane, and an adaptive step that moves fast
  // water 0.4 spacing per step carries it through: water at 2-3 m/s sliding along a floor left a
  // box tank through the end wall at the edge in 7 of 8 dam breaks at cfl 0.4, in none at 0.2
  // (mls: none at 0.4).
  if (s.solver.boundary_pressure == BoundaryPressureMethod::Mirroring && s.time_step.adaptive && s.time_step.cfl > 0.2)
    s.warnings.push_back("solver.boundary_pressure mirroring with time_step.cfl " + numberText(s.time_step.cfl) +
                         ": fast water (2-3 m/s) can cross walls where they meet at this step (its wall pushes only "
                         "with the particle's own pressure); use time_step.cfl 0.2 or less, or mls");
  // A probe outside the domain is legal but can only ever read dry: most likely a typo.
  for (std::size_t i = 0; i < s.probes.size(); ++i)
  {
    const Vec3d& p = s.probes[i].position;
    if (!s.domain.contains(p))
      s.warnings.push_back("probes[" + std::to_string(i) + "] '" + s.probes[i].name + "': position (" +
                           numberText(p.x()) + ", " + numberText(p.y()) + ", " + numberText(p.z()) +
                           ") lies outside the domain, where there is never water: it will read dry");
  }
  // So is a box or sphere region or sink that misses the domain altogether (a body region moves
  // with its body).
  const auto missesDomain = [&](const RegionConfig& region) {
    AxisBox bounds;
    if (region.shape == RegionShape::Sphere)
      bounds = {region.sphere.center - Vec3d::Constant(region.sphere.radius),
                region.sphere.center + Vec3d::Constant(region.sphere.radius)};
    else if (region.shape == RegionShape::Box)
    {
      bounds.min = Vec3d::Constant(std::numeric_limits<double>::infinity());
      bounds.max = -bounds.min;
      for (int k = 0; k < 8; ++k)
      {
        const Vec3d corner((k & 1) ? region.box.max.x() : region.box.min.x(),
                           (k & 2) ? region.box.max.y() : region.box.min.y(),
                           (k & 4) ? region.box.max.z() : region.box.min.z());
        const Vec3d world = region.pose.apply(corner);
        bounds.min = bounds.min.cwiseMin(world);
        bounds.max = bounds.max.cwiseMax(world);
      }
    }
    else
      return false;
    return (bounds.max.array() < s.domain.min.array()).any() || (bounds.min.array() > s.domain.max.array()).any();
  };
  for (const auto& [list, key] : {std::make_pair(&s.regions, "regions"), std::make_pair(&s.sinks, "sinks")})
    for (std::size_t i = 0; i < list->size(); ++i)
      if (missesDomain((*list)[i]))
        s.warnings.push_back(std::string(key) + "[" + std::to_string(i) + "] '" + (*list)[i].name +
                             "' lies wholly outside the domain, where there is never water: it will stay empty");
  return s;
}

}  // namespace

SceneConfig parseScene(const std::string& yaml_text, const std::string& source_name,
                       const std::vector<std::string>& overrides, const SceneLoadOptions& options)
{
  std::vector<SceneOverride> applied;
  try
  {
    YAML::Node root = yaml::parse(yaml_text);
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
  std::string text;
  try
  {
    text = readTextFile(path, "scene file");
  }
  catch (const ConfigError& e)
  {
    throw SceneError(path, "", e.message());
  }
  return parseScene(text, path, overrides, options);
}

}  // namespace io
}  // namespace fluid_sim
