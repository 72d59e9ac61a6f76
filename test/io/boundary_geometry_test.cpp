// Boundaries from mesh files in a running simulation: the sampled layer covers every fixture
// surface evenly, a box read from an STL acts as the same box given as a primitive (floor force of
// a settled column, buoyancy of a submerged cube), and a thin-walled open cup holds water.
// Small scenes at spacing 2 cm, as in test/core/hydrostatic_test.cpp.

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <random>
#include <string>
#include <unordered_map>

#include "fluid_sim/core/boundary_sampling.h"
#include "fluid_sim/core/measurements.h"
#include "fluid_sim/core/simulation.h"
#include "fluid_sim/io/mesh_loader.h"
#include "fluid_sim/io/scene_loader.h"
#include "fluid_sim/io/urdf_loader.h"

namespace fluid_sim
{
namespace
{
const std::string kFixtures = FLUID_SIM_SOURCE_DIR "/test/fixtures";
const std::string kMeshes = kFixtures + "/fluid_sim_test_pkg/meshes/";
constexpr double kG = 9.81;

/// Distance from p to the nearest of `points`, through a hash grid of cell `cell`.
class NearestPoint
{
public:
  NearestPoint(const std::vector<Vec3d>& points, double cell) : points_(points), cell_(cell)
  {
    for (std::size_t i = 0; i < points.size(); ++i) cells_[key(points[i])].push_back(i);
  }
  double distance(const Vec3d& p) const
  {
    const Key k = key(p);
    double best = std::numeric_limits<double>::infinity();
    for (long long dz = -1; dz <= 1; ++dz)
      for (long long dy = -1; dy <= 1; ++dy)
        for (long long dx = -1; dx <= 1; ++dx)
        {
          const auto it = cells_.find({k[0] + dx, k[1] + dy, k[2] + dz});
          if (it == cells_.end()) continue;
          for (std::size_t i : it->second) best = std::min(best, (points_[i] - p).norm());
        }
    return best;  // exact when below cell
  }

private:
  using Key = std::array<long long, 3>;
  struct KeyHash
  {
    std::size_t operator()(const Key& k) const
    {
      return std::size_t(k[0] * 73856093LL ^ k[1] * 19349663LL ^ k[2] * 83492791LL);
    }
  };
  Key key(const Vec3d& p) const
  {
    return {(long long)std::floor(p.x() / cell_), (long long)std::floor(p.y() / cell_),
            (long long)std::floor(p.z() / cell_)};
  }
  const std::vector<Vec3d>& points_;
  double cell_;
  std::unordered_map<Key, std::vector<std::size_t>, KeyHash> cells_;
};

struct Coverage
{
  double max_gap = 0.0;   // largest distance from a random surface point to a sample, m
  double min_dist = 0.0;  // smallest distance between two samples, m
  std::size_t samples = 0;
};

Coverage coverage(const TriangleMesh& mesh, double s)
{
  const std::vector<Vec3d> samples = sampleMeshSurface(mesh, s, 0.0);
  Coverage c;
  c.samples = samples.size();
  const NearestPoint nearest(samples, 2.0 * s);
  std::vector<double> cumulative;
  double area = 0.0;
  for (const auto& t : mesh.triangles)
  {
    const Vec3d& a = mesh.vertices[t[0]];
    area += 0.5 * (mesh.vertices[t[1]] - a).cross(mesh.vertices[t[2]] - a).norm();
    cumulative.push_back(area);
  }
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  for (int k = 0; k < 20000; ++k)
  {
    const std::size_t t = std::lower_bound(cumulative.begin(), cumulative.end(), u01(rng) * area) - cumulative.begin();
    const auto& tri = mesh.triangles[std::min(t, mesh.triangles.size() - 1)];
    double u = u01(rng), v = u01(rng);
    if (u + v > 1.0) u = 1.0 - u, v = 1.0 - v;
    const Vec3d& a = mesh.vertices[tri[0]];
    const Vec3d p = a + u * (mesh.vertices[tri[1]] - a) + v * (mesh.vertices[tri[2]] - a);
    c.max_gap = std::max(c.max_gap, nearest.distance(p));
  }
  c.min_dist = std::numeric_limits<double>::infinity();
  for (const auto& p : samples)
  {
    // Nearest other sample: the nearest point is p itself, so look for the second one.
    double best = std::numeric_limits<double>::infinity();
    for (const auto& q : samples)
      if (&q != &p && (q - p).squaredNorm() < 4.0 * s * s) best = std::min(best, (q - p).norm());
    c.min_dist = std::min(c.min_dist, best);
    if (samples.size() > 3000) break;  // the quadratic check on a prefix is enough
  }
  return c;
}

TEST(BoundaryGeometry, SamplesCoverEveryFixtureSurfaceEvenly)
{
  const double s = 0.02;
  io::UrdfBoundaryOptions options;
  options.spacing = s;
  options.packages = io::defaultPackageResolver({kFixtures});
  options.exact_primitives = false;  // the tessellated box, cylinder and sphere too
  const auto links = io::urdfBoundaries(io::readUrdfFile(kFixtures + "/fluid_sim_test_pkg/urdf/shapes.urdf"), options);
  std::vector<std::pair<std::string, TriangleMesh>> surfaces = {
      {"unit_cube.stl x 0.3", io::readMeshFile(kMeshes + "unit_cube.stl", Vec3d::Constant(0.3)).mesh},
      {"cube_inward.stl", io::readMeshFile(kMeshes + "cube_inward.stl", Vec3d(0.2, 0.3, 0.4)).mesh},
      {"pyramid.obj", io::readMeshFile(kMeshes + "pyramid.obj", Vec3d(0.3, 0.2, 0.5)).mesh},
      {"two_cubes_cm.dae", io::readMeshFile(kMeshes + "two_cubes_cm.dae").mesh},
      {"unit_cube.ply", io::readMeshFile(kMeshes + "unit_cube.ply", Vec3d::Constant(0.1)).mesh},
      {"cup.stl", io::readMeshFile(kMeshes + "cup.stl").mesh}};
  for (const auto& b : links) surfaces.emplace_back("link " + b.name, b.mesh);
  for (const auto& [name, mesh] : surfaces)
  {
    const Coverage c = coverage(mesh, s);
    EXPECT_LT(c.max_gap, 0.75 * s) << name << ": " << c.samples << " samples";
    EXPECT_GE(c.min_dist, 0.6 * s) << name;
    std::printf("coverage %-22s %6zu samples, %.2f per s^2, max gap %.3f s, min distance %.3f s\n", name.c_str(),
                c.samples, c.samples * s * s / meshArea(mesh), c.max_gap / s, c.min_dist / s);
  }
  // Deterministic: the same samples in the same order.
  const TriangleMesh& cup = surfaces[5].second;
  EXPECT_EQ(sampleMeshSurface(cup, s, 0.0), sampleMeshSurface(cup, s, 0.0));
}

/// A column of water, `width` square and `depth` deep, in a tank given by `tank` (a YAML boundary
/// entry) and optionally a submerged cube (another entry).
SceneConfig column(const std::string& tank, const std::string& cube, double width, double depth)
{
  char text[1024];
  std::snprintf(text, sizeof text, R"yaml(
spacing: 0.02
domain: {min: [-0.1, -0.1, -0.1], max: [%g, %g, %g]}
time_step: {fixed: 0.001}
viscosity: {model: xsph, coefficient: 0.01}
fluid:
  - box: {min: [0, 0, 0], max: [%g, %g, %g]}
)yaml",
                width + 0.1, width + 0.1, depth + 0.3, width, width, depth);
  return io::parseScene(std::string(text) + "boundaries:\n" + tank + cube, kFixtures + "/scene.yaml");
}

std::string boxTank(bool as_mesh, double width, double height)
{
  char text[512];
  if (as_mesh)
    std::snprintf(text, sizeof text,
                  "  - name: tank\n    mesh: {file: fluid_sim_test_pkg/meshes/unit_cube.stl, scale: [%g, %g, %g]}\n"
                  "    inside: true\n",
                  width, width, height);
  else
    std::snprintf(text, sizeof text, "  - name: tank\n    box: {min: [0, 0, 0], max: [%g, %g, %g]}\n    inside: true\n",
                  width, width, height);
  return text;
}

std::string cube(bool as_mesh, const Vec3d& lo, double side)
{
  char text[512];
  if (as_mesh)
    std::snprintf(text, sizeof text,
                  "  - name: cube\n    mesh: {file: fluid_sim_test_pkg/meshes/unit_cube.stl, scale: %g}\n"
                  "    pose: {xyz: [%g, %g, %g]}\n",
                  side, lo.x(), lo.y(), lo.z());
  else
    std::snprintf(text, sizeof text, "  - name: cube\n    box: {min: [%g, %g, %g], max: [%g, %g, %g]}\n", lo.x(),
                  lo.y(), lo.z(), lo.x() + side, lo.y() + side, lo.z() + side);
  return text;
}

/// Mean force (world, N) on body `index` over [settle, settle + window] s.
Vec3d meanForce(Simulation& sim, std::size_t index, double settle, double window)
{
  Vec3d sum = Vec3d::Zero();
  int steps = 0;
  while (sim.time() < settle + window - 1e-9)
  {
    const StepReport r = sim.step();
    EXPECT_FALSE(r.unstable) << r.reason;
    if (r.unstable) break;
    if (sim.time() <= settle) continue;
    sum += sim.body(index).force;
    ++steps;
  }
  return steps ? Vec3d(sum / steps) : Vec3d(Vec3d::Zero());
}

TEST(BoundaryGeometry, StlTankGivesTheSameFloorForceAsTheBoxPrimitive)
{
  const double width = 0.2, depth = 0.3;
  Simulation primitive(column(boxTank(false, width, depth + 0.2), "", width, depth));
  Simulation mesh(column(boxTank(true, width, depth + 0.2), "", width, depth));
  ASSERT_EQ(primitive.numFluidParticles(), mesh.numFluidParticles());
  const double weight = primitive.numFluidParticles() * primitive.particleMass() * kG;
  const Vec3d f_primitive = meanForce(primitive, 0, 0.5, 0.3);
  const Vec3d f_mesh = meanForce(mesh, 0, 0.5, 0.3);
  std::printf("floor force / weight: primitive %.4f, STL %.4f (%zu and %zu boundary particles)\n",
              -f_primitive.z() / weight, -f_mesh.z() / weight, primitive.boundaryPositions().size(),
              mesh.boundaryPositions().size());
  EXPECT_NEAR(f_mesh.z() / f_primitive.z(), 1.0, 0.02);
  EXPECT_NEAR(-f_mesh.z() / weight, 1.0, 0.02);
  EXPECT_EQ(mesh.removedTotal(), 0u);
}

TEST(BoundaryGeometry, StlCubeFeelsTheSameBuoyancyAsTheBoxPrimitive)
{
  const double width = 0.24, depth = 0.24, side = 0.08;
  const Vec3d lo(0.08, 0.08, 0.08);
  Simulation primitive(column(boxTank(false, width, depth + 0.2), cube(false, lo, side), width, depth));
  Simulation mesh(column(boxTank(true, width, depth + 0.2), cube(true, lo, side), width, depth));
  // The STL cube removes the same lattice points as the primitive (its inside test is exact).
  EXPECT_EQ(primitive.removedAtStart(), 64u);
  EXPECT_EQ(mesh.removedAtStart(), 64u);
  const double archimedes = 1000.0 * kG * side * side * side;
  const Vec3d b_primitive = meanForce(primitive, 1, 0.4, 0.3);
  const Vec3d b_mesh = meanForce(mesh, 1, 0.4, 0.3);
  // Both layers are the same points (a box face's lattice is the primitive's), so the runs agree.
  EXPECT_EQ(primitive.body(1).num_particles, mesh.body(1).num_particles);
  std::printf("buoyancy / rho g V: primitive %.4f, STL %.4f (ratio %.4f)\n", b_primitive.z() / archimedes,
              b_mesh.z() / archimedes, b_mesh.z() / b_primitive.z());
  EXPECT_NEAR(b_mesh.z() / b_primitive.z(), 1.0, 0.05);
  EXPECT_NEAR(b_mesh.z() / archimedes, 1.0, 0.1);
}

TEST(BoundaryGeometry, StlSphereFeelsAboutTheSameBuoyancyAsTheSpherePrimitive)
{
  // A faceted sphere is sampled by the general path (facet lattices, fill), the primitive by a
  // Fibonacci lattice: the two layers differ point by point but should push alike.
  const double width = 0.24, depth = 0.24, r = 0.05;
  const std::string primitive_sphere = "  - name: ball\n    sphere: {center: [0.12, 0.12, 0.12], radius: 0.05}\n";
  const std::string mesh_sphere =
      "  - name: ball\n    mesh: {file: fluid_sim_test_pkg/meshes/unit_sphere.stl, scale: 0.05}\n"
      "    pose: {xyz: [0.12, 0.12, 0.12]}\n";
  Simulation primitive(column(boxTank(false, width, depth + 0.2), primitive_sphere, width, depth));
  Simulation mesh(column(boxTank(false, width, depth + 0.2), mesh_sphere, width, depth));
  const double archimedes = 1000.0 * kG * 4.0 / 3.0 * M_PI * r * r * r;
  const Vec3d b_primitive = meanForce(primitive, 1, 0.4, 0.3);
  const Vec3d b_mesh = meanForce(mesh, 1, 0.4, 0.3);
  std::printf("sphere buoyancy / rho g V: primitive %.4f, STL %.4f (ratio %.4f; %zu and %zu boundary particles)\n",
              b_primitive.z() / archimedes, b_mesh.z() / archimedes, b_mesh.z() / b_primitive.z(),
              primitive.body(1).num_particles, mesh.body(1).num_particles);
  EXPECT_NEAR(b_mesh.z() / b_primitive.z(), 1.0, 0.05);
}

TEST(BoundaryGeometry, ThinWalledCupHoldsWater)
{
  // The cup (radius 0.1 m, 0.16 m high, open top, walls of zero thickness) on the floor of a tank,
  // filled to 0.1 m with a block that clears its wall by a spacing.
  const std::string yaml = R"yaml(
spacing: 0.02
domain: {min: [-0.25, -0.25, -0.1], max: [0.25, 0.25, 0.4]}
time_step: {fixed: 0.001}
viscosity: {model: xsph, coefficient: 0.01}
fluid:
  - box: {min: [-0.06, -0.06, 0.01], max: [0.06, 0.06, 0.13]}
boundaries:
  - name: tank
    box: {min: [-0.2, -0.2, -0.05], max: [0.2, 0.2, 0.35]}
    inside: true
  - name: cup
    mesh: {file: fluid_sim_test_pkg/meshes/cup.stl}
)yaml";
  SceneConfig scene = io::parseScene(yaml, kFixtures + "/scene.yaml");
  ASSERT_EQ(scene.warnings.size(), 1u);  // open mesh used as a solid
  Simulation sim(scene);
  const std::size_t n = sim.numFluidParticles();
  std::size_t max_outside = 0;
  while (sim.time() < 0.6)
  {
    const StepReport r = sim.step();
    ASSERT_FALSE(r.unstable) << r.reason;
    std::size_t outside = 0;
    for (const auto& x : sim.positions())
      if (x.head<2>().norm() > 0.1 || x.z() < 0.0) ++outside;
    max_outside = std::max(max_outside, outside);
  }
  std::printf("cup: %zu particles, at most %zu outside the wall, %zu boundary particles\n", n, max_outside,
              sim.boundaryPositions().size());
  EXPECT_EQ(max_outside, 0u);
  EXPECT_EQ(sim.numFluidParticles(), n);
}

TEST(BoundaryGeometry, CupRegionReadsTheWaterItHolds)
{
  // The issue's check: a cup holding 0.3 l reads 0.3 l within 2 % at 5 mm. The open cup mesh
  // scaled to radius 8 cm and height 12.8 cm (2.57 l up to its rim) stands in a tank with 0.3 l
  // in it (20 x 20 x 6 lattice points) and 0.165 l outside it, against its wall; after 0.15 s the
  // region `cup` (the mesh closed over its rim) holds the first and none of the second.
  const std::string yaml = R"yaml(
spacing: 0.005
domain: {min: [-0.15, -0.15, -0.05], max: [0.15, 0.15, 0.25]}
time_step: {cfl: 0.4, max: 0.002}
viscosity: {model: xsph, coefficient: 0.01}
fluid:
  - box: {min: [-0.05, -0.05, 0.005], max: [0.05, 0.05, 0.035]}
  - box: {min: [0.09, -0.11, 0.0], max: [0.115, 0.11, 0.03]}
boundaries:
  - name: tank
    box: {min: [-0.12, -0.12, -0.005], max: [0.12, 0.12, 0.2]}
    inside: true
  - name: cup
    mesh: {file: fluid_sim_test_pkg/meshes/cup.stl, scale: 0.8}
    offset: none
regions:
  - {name: cup, body: cup}
)yaml";
  const SceneConfig scene = io::parseScene(yaml, kFixtures + "/scene.yaml");
  Simulation sim(scene);
  Measurements m(sim);
  const double poured = 20 * 20 * 6 * std::pow(0.005, 3);  // m^3, the block in the cup
  ASSERT_NEAR(poured, 0.3e-3, 1e-12);
  MeasurementReport r = m.evaluate(sim);
  ASSERT_EQ(r.regions.size(), 1u);
  // The mesh's 48-gon: 0.3 % less than the cylinder's pi r^2 h.
  const double cylinder = M_PI * 0.08 * 0.08 * 0.128;  // m^3
  EXPECT_NEAR(r.regions[0].capacity / cylinder, 1.0, 0.004);
  EXPECT_LT(r.regions[0].capacity, cylinder);
  while (sim.time() < 0.15)
  {
    const StepReport rep = sim.step();
    ASSERT_FALSE(rep.unstable) << rep.reason;
  }
  r = m.evaluate(sim);
  std::printf("cup: %zu particles inside, %.4f l (poured 0.3 l), fill fraction %.4f, %zu particles in all\n",
              r.regions[0].particles, 1000.0 * r.regions[0].volume, r.regions[0].fill_fraction,
              sim.numFluidParticles());
  EXPECT_NEAR(r.regions[0].volume / poured, 1.0, 0.02);
  EXPECT_NEAR(r.regions[0].fill_fraction, r.regions[0].volume / r.regions[0].capacity, 1e-12);
}

}  // namespace
}  // namespace fluid_sim
