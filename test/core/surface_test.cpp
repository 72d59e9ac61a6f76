// The free-surface mesh (surface.h; docs/method.md, Free-surface mesh, Eqs. A28-A30): a lattice
// block's mesh encloses the particles' volume and has its top face at the water's height, the
// mesh is closed and oriented outward, no particle gives no mesh, non-finite positions are left
// out, and the voxel budget refuses a huge box naming the count.
//
// DISABLED_RadiusAndVoxelChoice measures the errors and the cost behind the defaults (the table
// in docs/method.md):
//   build/devel/lib/fluid_sim/surface_test --gtest_also_run_disabled_tests --gtest_filter='*Choice'

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <utility>
#include <vector>

#include "fluid_sim/core/simulation.h"
#include "fluid_sim/core/surface.h"

using namespace fluid_sim;

namespace
{
/// The lattice points of a block of nx x ny x nz particles at spacing s, filling the box from
/// `origin` (m) to origin + (nx, ny, nz) s: the centres of its cells, as the initial fill makes them.
std::vector<Vec3> block(int nx, int ny, int nz, double s, const Vec3d& origin = Vec3d::Zero())
{
  std::vector<Vec3> p;
  for (int i = 0; i < nx; ++i)
    for (int j = 0; j < ny; ++j)
      for (int k = 0; k < nz; ++k) p.push_back((origin + s * Vec3d(i + 0.5, j + 0.5, k + 0.5)).cast<Real>());
  return p;
}

/// The lattice points (spacing s, cells centred as above) whose centre is within `radius` (m) of
/// `center`.
std::vector<Vec3> ball(double radius, double s, const Vec3d& center)
{
  std::vector<Vec3> p;
  const int n = int(std::ceil(radius / s)) + 1;
  for (int i = -n; i <= n; ++i)
    for (int j = -n; j <= n; ++j)
      for (int k = -n; k <= n; ++k)
      {
        const Vec3d x = s * Vec3d(i + 0.5, j + 0.5, k + 0.5);
        if (x.norm() <= radius) p.push_back((center + x).cast<Real>());
      }
  return p;
}

/// Edges used by other than exactly two triangles that run along them in opposite directions:
/// 0 for a closed, consistently oriented mesh.
std::size_t badEdges(const SurfaceMesh& mesh)
{
  std::map<std::pair<Index, Index>, int> directed;  // (from, to) -> triangles running along it
  for (const auto& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) ++directed[{t[k], t[(k + 1) % 3]}];
  std::size_t bad = 0;
  for (const auto& [edge, count] : directed)
  {
    const auto back = directed.find({edge.second, edge.first});
    if (count != 1 || back == directed.end() || back->second != 1) ++bad;
  }
  return bad;
}

/// Connected pieces of the mesh (triangles sharing vertices): 1 for a block of water, more if
/// the mesh had hollows inside it or drops beside it.
std::size_t pieces(const SurfaceMesh& mesh)
{
  std::vector<Index> parent(mesh.vertices.size());
  for (Index i = 0; i < parent.size(); ++i) parent[i] = i;
  const auto root = [&](Index i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  for (const auto& t : mesh.triangles)
  {
    parent[root(t[0])] = root(t[1]);
    parent[root(t[1])] = root(t[2]);
  }
  std::size_t n = 0;
  for (Index i = 0; i < parent.size(); ++i) n += root(i) == i;
  return n;
}

/// The top face's height (m): the area-weighted mean z of the triangles that face up (normal
/// within 25 degrees of +z) over the middle of the block, x in [x0, x1], y in [y0, y1]; and the
/// spread of their vertices' z (max - min, m): the bumps between the particles.
struct TopFace
{
  double height = 0.0;
  double bumps = 0.0;
};
TopFace topFace(const SurfaceMesh& mesh, double x0, double x1, double y0, double y1)
{
  double area = 0.0, weighted = 0.0;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const auto& t : mesh.triangles)
  {
    const Vec3d a = mesh.vertices[t[0]].cast<double>(), b = mesh.vertices[t[1]].cast<double>(),
                c = mesh.vertices[t[2]].cast<double>();
    const Vec3d n = (b - a).cross(c - a);  // outward (counter-clockwise from outside), |n| = 2 area
    const Vec3d centroid = (a + b + c) / 3.0;
    if (n.norm() == 0.0 || n.z() < std::cos(25.0 * M_PI / 180.0) * n.norm()) continue;
    if (centroid.x() < x0 || centroid.x() > x1 || centroid.y() < y0 || centroid.y() > y1) continue;
    area += 0.5 * n.norm();
    weighted += 0.5 * n.norm() * centroid.z();
    for (const Vec3d* v : {&a, &b, &c})
    {
      lo = std::min(lo, v->z());
      hi = std::max(hi, v->z());
    }
  }
  TopFace f;
  f.height = area > 0.0 ? weighted / area : std::numeric_limits<double>::quiet_NaN();
  f.bumps = hi - lo;
  return f;
}

constexpr double kS = 0.02;  // m, the demo's spacing
}  // namespace

// The demo's water layer as a lattice: 30 x 20 x 6 particles at 2 cm (0.6 x 0.4 x 0.12 m).
TEST(Surface, LatticeBlockEnclosesTheParticleVolume)
{
  const std::vector<Vec3> p = block(30, 20, 6, kS);
  const SurfaceMesh mesh = reconstructSurface(p, kS);
  ASSERT_FALSE(mesh.empty());
  const double exact = double(p.size()) * kS * kS * kS;  // m^3, the particles' volume at rest density
  const double v = enclosedVolume(mesh);
  // Measured with the defaults (docs/method.md, Free-surface mesh): -1.3 % here, -1.3 to +1.3 %
  // with the block moved by quarters of a voxel (where its faces fall between the samples); the
  // smoothing rounds its edges, (1 - pi/4) r_e^2 per metre of edge, 1.3 % of this block for
  // r_e = s. The 2 % bound fails for a particle radius 0.02 s smaller (0.76 s: -3.2 %) or 0.06 s
  // larger (0.84 s: +3.1 %).
  EXPECT_NEAR(v / exact, 1.0, 0.02) << "enclosed " << v << " m^3 of " << exact;
}

TEST(Surface, TopFaceIsAtTheWaterHeight)
{
  const std::vector<Vec3> p = block(30, 20, 6, kS);
  const SurfaceMesh mesh = reconstructSurface(p, kS);
  // The water ends half a spacing above the top layer's centres (its cells end there): 0.12 m.
  const TopFace top = topFace(mesh, 0.15, 0.45, 0.1, 0.3);
  // Measured: -0.001 s here, -0.001 to +0.054 s with the block moved by quarters of a voxel. The
  // 0.08 s bound fails for a particle radius 0.06 s smaller (0.72 s: -0.12 s) or larger (0.84 s:
  // +0.09 s).
  EXPECT_NEAR(top.height, 6 * kS, 0.08 * kS) << "the top face's mean height";
  // Flat: the vertices over the middle of the face within 0.05 s of each other (measured 0.000;
  // without the smoothing the union of spheres and its hollows spread them over 5 s).
  EXPECT_LT(top.bumps, 0.05 * kS);
}

TEST(Surface, MeshIsClosedAndOrientedOutward)
{
  for (const auto& p : {block(30, 20, 6, kS), ball(8 * kS, kS, Vec3d(0.3, 0.2, 0.3))})
  {
    const SurfaceMesh mesh = reconstructSurface(p, kS);
    ASSERT_FALSE(mesh.empty());
    EXPECT_EQ(badEdges(mesh), 0u) << "edges not shared by two opposite triangles";
    EXPECT_EQ(pieces(mesh), 1u) << "a hollow inside the water, or a piece beside it";
    // Outward: the enclosed volume (divergence theorem) is positive, and the lowest triangle
    // (by its centroid, on the bottom face) faces down.
    EXPECT_GT(enclosedVolume(mesh), 0.0);
    double lowest = std::numeric_limits<double>::infinity();
    Vec3d normal = Vec3d::Zero();
    for (const auto& t : mesh.triangles)
    {
      ASSERT_TRUE(t[0] < mesh.vertices.size() && t[1] < mesh.vertices.size() && t[2] < mesh.vertices.size());
      const Vec3d a = mesh.vertices[t[0]].cast<double>(), b = mesh.vertices[t[1]].cast<double>(),
                  c = mesh.vertices[t[2]].cast<double>();
      if ((a + b + c).z() / 3.0 < lowest)
      {
        lowest = (a + b + c).z() / 3.0;
        normal = (b - a).cross(c - a);
      }
    }
    EXPECT_LT(normal.z(), 0.0) << "the bottom face's triangle faces up";
  }
  // A ball of particles (the lattice points within 8 spacings of a centre: 2,176): its mesh
  // encloses the particles' volume, measured +1.7 %; the 3 % bound fails for a particle radius
  // 0.06 s larger (+5.8 %).
  const std::vector<Vec3> p = ball(8 * kS, kS, Vec3d(0.3, 0.2, 0.3));
  const double exact = double(p.size()) * kS * kS * kS;
  EXPECT_NEAR(enclosedVolume(reconstructSurface(p, kS)) / exact, 1.0, 0.03);
}

TEST(Surface, ALoneParticleIsADrop)
{
  // Smoothed alone, its sphere (r = 0.78 s) would vanish (without Eq. A29b: no triangle at all);
  // Eq. A29b keeps a ball of radius r_d = 0.45 s. Sampled on voxels of s/3 (1.35 voxels of
  // radius) and meshed, it comes out smaller: measured 0.43 of its volume (an equivalent radius of
  // 0.34 s); bounds 0.3-0.6.
  const SurfaceMesh one = reconstructSurface({Vec3(0.1f, 0.1f, 0.1f)}, kS);
  ASSERT_FALSE(one.empty());
  EXPECT_EQ(badEdges(one), 0u);
  EXPECT_EQ(pieces(one), 1u);
  const double ball = 4.0 / 3.0 * M_PI * std::pow(0.45 * kS, 3);  // m^3
  EXPECT_NEAR(enclosedVolume(one) / ball, 0.45, 0.15) << enclosedVolume(one) / ball;
  // Two neighbours: one piece, closed.
  const SurfaceMesh two = reconstructSurface({Vec3(0.1f, 0.1f, 0.1f), Vec3(0.12f, 0.1f, 0.1f)}, kS);
  EXPECT_EQ(badEdges(two), 0u);
  EXPECT_EQ(pieces(two), 1u);
  EXPECT_GT(enclosedVolume(two), enclosedVolume(one));
}

TEST(Surface, NoParticlesGiveAnEmptyMesh)
{
  const SurfaceMesh none = reconstructSurface({}, kS);
  EXPECT_TRUE(none.empty());
  EXPECT_TRUE(none.vertices.empty());
  EXPECT_EQ(none.particles, 0u);
  EXPECT_EQ(enclosedVolume(none), 0.0);
  // Only non-finite positions: left out, so none either.
  const Real nan = std::numeric_limits<Real>::quiet_NaN();
  const SurfaceMesh all_nan = reconstructSurface({Vec3(nan, 0, 0), Vec3(0, nan, 0)}, kS);
  EXPECT_TRUE(all_nan.empty());
  EXPECT_EQ(all_nan.skipped_particles, 2u);
}

TEST(Surface, NonFinitePositionsAreLeftOut)
{
  std::vector<Vec3> p = block(6, 6, 6, kS);
  const SurfaceMesh clean = reconstructSurface(p, kS);
  p.push_back(Vec3(std::numeric_limits<Real>::quiet_NaN(), 0, 0));
  p.push_back(Vec3(0, std::numeric_limits<Real>::infinity(), 0));
  const SurfaceMesh mesh = reconstructSurface(p, kS);
  EXPECT_EQ(mesh.skipped_particles, 2u);
  EXPECT_EQ(mesh.particles, 216u);
  EXPECT_EQ(mesh.triangles.size(), clean.triangles.size());
  EXPECT_DOUBLE_EQ(enclosedVolume(mesh), enclosedVolume(clean));
}

TEST(Surface, VoxelBudgetRefusesAHugeBoxNamingTheCount)
{
  // Two particles 1 km apart at 2 cm spacing: 1000 m of voxels along x, far more than a budget
  // of 1e6 voxels; refused before anything is allocated.
  SurfaceOptions o;
  o.max_voxels = 1.0e6;
  const std::vector<Vec3> p = {Vec3(0, 0, 0), Vec3(1000, 0, 0)};
  try
  {
    reconstructSurface(p, kS, o);
    FAIL() << "no error for a box of 1 km at 5 mm voxels";
  }
  catch (const ConfigError& e)
  {
    const std::string what = e.what();
    EXPECT_EQ(e.key(), "surface");
    // Voxels of s/3 = 6.67 mm, the box widened by r + 3 voxels = 35.6 mm each side: 150,012 along
    // x times 12 x 12 across.
    EXPECT_NE(what.find("2.16017e+07 voxels"), std::string::npos) << what;
    EXPECT_NE(what.find("budget of 1e+06"), std::string::npos) << what;
  }
  // The default budget (4e9) refuses a particle 10 km away in all three directions.
  try
  {
    reconstructSurface({Vec3(0, 0, 0), Vec3(1e4, 1e4, 1e4)}, kS);
    FAIL() << "no error for a box of 10 km";
  }
  catch (const ConfigError& e)
  {
    EXPECT_NE(std::string(e.what()).find("more than the budget of 4e+09"), std::string::npos) << e.what();
  }
}

TEST(Surface, BadOptionsAreNamed)
{
  SurfaceOptions o;
  o.voxel_size = 1.0;  // coarser than the spheres: every particle would vanish
  try
  {
    reconstructSurface(block(2, 2, 2, kS), kS, o);
    FAIL();
  }
  catch (const ConfigError& e)
  {
    EXPECT_NE(std::string(e.what()).find("voxel_size = 1 spacings"), std::string::npos) << e.what();
  }
  EXPECT_THROW(reconstructSurface(block(2, 2, 2, kS), 0.0), ConfigError);
  EXPECT_THROW(reconstructSurface(block(2, 2, 2, kS), std::nan("")), ConfigError);
}

// ------------------------------------------------------------------------------ measurement
namespace
{
/// The demo's tank (0.6 x 0.4 m, water 0.12 m deep at 2 cm) settled for `seconds`: the water as
/// the simulation leaves it, no longer a lattice.
std::vector<Vec3> settledDemoWater(double seconds)
{
  SceneConfig s;
  s.spacing = kS;
  s.domain = {Vec3d(-0.1, -0.1, -0.1), Vec3d(0.7, 0.5, 0.7)};
  s.time_step.adaptive = true;
  s.time_step.cfl = 0.4;
  s.time_step.max = 0.004;
  s.solver.warm_start = true;
  s.viscosity.model = ViscosityModel::Xsph;
  s.viscosity.coefficient = 0.05;
  s.viscosity.boundary = 0.05;
  FluidBlockConfig f;
  f.box = {Vec3d(0, 0, 0), Vec3d(0.6, 0.4, 0.12)};
  s.fluid.push_back(f);
  BoundaryConfig tank;
  tank.name = "tank";
  tank.type = ShapeType::Box;
  tank.box = {Vec3d(0, 0, 0), Vec3d(0.6, 0.4, 0.5)};
  tank.inside = true;
  s.boundaries.push_back(tank);
  Simulation sim(s);
  while (sim.time() < seconds) sim.step();
  return sim.positions();
}

double msOf(const std::vector<Vec3>& p, double s, const SurfaceOptions& o, int repeats)
{
  double best = std::numeric_limits<double>::infinity();
  for (int k = 0; k < repeats; ++k) best = std::min(best, reconstructSurface(p, s, o).ms);
  return best;
}
}  // namespace

/// The mean height (m) of the highest particle of each column (x, y in cells of `s` over the
/// middle of the tank, x in [x0, x1], y in [y0, y1]): where the top layer's centres are.
double topLayer(const std::vector<Vec3>& p, double s, double x0, double x1, double y0, double y1)
{
  std::map<std::pair<int, int>, double> top;
  for (const Vec3& x : p)
  {
    if (x.x() < x0 || x.x() > x1 || x.y() < y0 || x.y() > y1) continue;
    const auto key = std::make_pair(int(std::floor(x.x() / s)), int(std::floor(x.y() / s)));
    const auto it = top.find(key);
    if (it == top.end() || it->second < x.z()) top[key] = x.z();
  }
  double sum = 0.0;
  for (const auto& [key, z] : top) sum += z;
  return top.empty() ? 0.0 : sum / double(top.size());
}

TEST(Surface, DISABLED_RadiusAndVoxelChoice)
{
  const std::vector<Vec3> lattice = block(30, 20, 6, kS);
  const std::vector<Vec3> sphere = ball(8 * kS, kS, Vec3d(0.3, 0.2, 0.3));
  const std::vector<Vec3> settled = settledDemoWater(1.0);
  // The demo's layer at 1.1 cm (the benchmark's 19 k size): 54 x 36 x 11 = 21,384 particles.
  const double s20 = 0.011;
  const std::vector<Vec3> lattice20 = block(54, 36, 11, s20);
  const double v_lattice = double(lattice.size()) * kS * kS * kS;
  const double v_sphere = double(sphere.size()) * kS * kS * kS;
  const double v_settled = double(settled.size()) * kS * kS * kS;
  const double h_settled = v_settled / (0.6 * 0.4);  // m, the settled water's height at rest density
  // The settled water's top layer of particles: half a spacing below the surface the mesh should find.
  const double layer = topLayer(settled, kS, 0.15, 0.45, 0.1, 0.3);
  std::printf(
      "lattice %zu, sphere %zu, settled %zu particles (height %.4f m at rest density; its top layer's centres at "
      "%.4f m, %+.3f s from height - s/2), 20k lattice %zu\n",
      lattice.size(), sphere.size(), settled.size(), h_settled, layer, (layer - (h_settled - 0.5 * kS)) / kS,
      lattice20.size());
  std::printf(
      "| r (s) | dx (s) | passes | lattice volume | lattice top (s) | ball volume | settled volume | settled top - top "
      "layer - s/2 (s) | triangles | ms 3.6 k | ms 21 k |\n");
  struct Choice
  {
    double r, h;
    int passes;
  };
  const std::vector<Choice> choices = {{0.78, 1.0 / 3.0, 0},  // no smoothing
                                       {0.64, 0.25, 1},      {0.70, 0.25, 1},      {0.72, 0.25, 1},
                                       {0.76, 0.25, 1},      {0.76, 0.25, 2},  // h = s/4
                                       {0.72, 1.0 / 3.0, 1}, {0.76, 1.0 / 3.0, 1}, {0.78, 1.0 / 3.0, 1},
                                       {0.80, 1.0 / 3.0, 1}, {0.84, 1.0 / 3.0, 1}, {0.84, 1.0 / 3.0, 2},  // h = s/3
                                       {0.80, 0.5, 1},       {0.90, 0.5, 1},       {1.00, 0.5, 1},        // h = s/2
                                       {0.64, 1.0 / 6.0, 1}, {0.68, 1.0 / 6.0, 1}};                       // h = s/6
  for (const Choice& c : choices)
  {
    SurfaceOptions o;
    o.particle_radius = c.r;
    o.voxel_size = c.h;
    o.smoothing_passes = c.passes;
    // The block moved by 0, 1/4, 1/2 and 3/4 of a voxel along every axis: where its faces fall
    // between the grid's samples matters; the range over the four.
    double v_lo = std::numeric_limits<double>::infinity(), v_hi = -v_lo, t_lo = v_lo, t_hi = -v_lo;
    std::size_t triangles = 0, most_pieces = 0;
    for (int k = 0; k < 4; ++k)
    {
      const double d = 0.25 * k * c.h * kS;  // m
      const SurfaceMesh m = reconstructSurface(block(30, 20, 6, kS, Vec3d(d, d, d)), kS, o);
      const double v = enclosedVolume(m) / v_lattice - 1.0;
      const double t = (topFace(m, 0.15 + d, 0.45 + d, 0.1 + d, 0.3 + d).height - 6 * kS - d) / kS;
      v_lo = std::min(v_lo, v);
      v_hi = std::max(v_hi, v);
      t_lo = std::min(t_lo, t);
      t_hi = std::max(t_hi, t);
      if (k == 0) triangles = m.triangles.size();
      most_pieces = std::max(most_pieces, pieces(m));
    }
    const SurfaceMesh ms = reconstructSurface(sphere, kS, o);
    const SurfaceMesh mt = reconstructSurface(settled, kS, o);
    const TopFace settled_top = topFace(mt, 0.15, 0.45, 0.1, 0.3);
    std::printf(
        "| %.2f | %.3f | %d | %+.2f..%+.2f %% | %+.3f..%+.3f | %+.2f %% | %+.2f %% | %+.3f | %zu%s | %.0f | %.0f |\n",
        c.r, c.h, c.passes, 100.0 * v_lo, 100.0 * v_hi, t_lo, t_hi, 100.0 * (enclosedVolume(ms) / v_sphere - 1.0),
        100.0 * (enclosedVolume(mt) / v_settled - 1.0), (settled_top.height - layer - 0.5 * kS) / kS, triangles,
        most_pieces > 1 ? (" (" + std::to_string(most_pieces) + " pieces)").c_str() : "", msOf(lattice, kS, o, 3),
        c.h >= 0.25 && c.passes == 1 ? msOf(lattice20, s20, o, 2) : 0.0);
    std::fflush(stdout);
  }
}
