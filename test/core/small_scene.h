#pragma once
// A small valid scene for the core's tests: a 0.2 m fluid cube at 5 cm spacing in a 0.8 m domain,
// no boundaries. Tests change one value and check what the core makes of it.
#include <cmath>
#include <string>
#include <vector>

#include "fluid_sim/core/scene_config.h"
#include "fluid_sim/core/simulation.h"

namespace fluid_sim
{
namespace test
{
inline SceneConfig smallScene()
{
  SceneConfig s;
  s.spacing = 0.05;
  s.domain = {Vec3d(-0.2, -0.2, -0.2), Vec3d(0.6, 0.6, 0.6)};
  FluidBlockConfig f;
  f.box = {Vec3d(0, 0, 0), Vec3d(0.2, 0.2, 0.2)};
  s.fluid.push_back(f);
  return s;
}

/// A box tank of `size` (m, min corner at the origin, open above the water) holding a water layer
/// `depth` (m) deep at spacing `s` (m), in a domain 0.1 m larger on every side; a fixed 1 ms step
/// and XSPH 0.01. Without water (depth 0), a drop of 8 particles in a corner (a scene needs fluid).
inline SceneConfig waterTank(double s, const Vec3d& size, double depth)
{
  SceneConfig scene;
  scene.spacing = s;
  scene.domain = {Vec3d(-0.1, -0.1, -0.1), size + Vec3d(0.1, 0.1, 0.1)};
  scene.time_step.fixed = 0.001;
  scene.viscosity.model = ViscosityModel::Xsph;
  scene.viscosity.coefficient = 0.01;
  BoundaryConfig t;
  t.name = "tank";
  t.type = ShapeType::Box;
  t.box = {Vec3d::Zero(), size};
  t.inside = true;
  scene.boundaries.push_back(t);
  FluidBlockConfig f;
  f.box = {Vec3d::Zero(), depth > 0.0 ? Vec3d(size.x(), size.y(), depth) : Vec3d(2 * s, 2 * s, 2 * s)};
  scene.fluid.push_back(f);
  return scene;
}

/// The key of the ConfigError that building a Simulation of `s` throws, or "<no error>".
inline std::string errorKey(const SceneConfig& s)
{
  try
  {
    Simulation sim(s);
  }
  catch (const ConfigError& e)
  {
    return e.key();
  }
  return "<no error>";
}
/// A mesh cylinder of `facets` side faces (radius r, height h, base at z = 0), normals out, closed
/// or open at the top (a cup).
inline TriangleMesh cylinderMesh(int facets, double r, double h, bool closed = true)
{
  TriangleMesh m;
  m.vertices.push_back(Vec3d(0, 0, 0));
  m.vertices.push_back(Vec3d(0, 0, h));
  for (int k = 0; k < facets; ++k)
  {
    const double a = 2.0 * M_PI * k / facets;
    m.vertices.push_back(Vec3d(r * std::cos(a), r * std::sin(a), 0.0));
    m.vertices.push_back(Vec3d(r * std::cos(a), r * std::sin(a), h));
  }
  for (int k = 0; k < facets; ++k)
  {
    const int a0 = 2 + 2 * k, a1 = a0 + 1, b0 = 2 + 2 * ((k + 1) % facets), b1 = b0 + 1;
    m.triangles.push_back({a0, b0, b1});
    m.triangles.push_back({a0, b1, a1});
    m.triangles.push_back({0, b0, a0});
    if (closed) m.triangles.push_back({1, a1, b1});
  }
  return m;
}

/// A closed mesh bowl: a hemisphere of radius r (lowest point at the origin) with `around` x
/// `down` facets, a cylindrical wall from its rim up to z = h, and a flat lid; normals out.
inline TriangleMesh bowlMesh(double r, double h, int around, int down)
{
  TriangleMesh m;
  m.vertices.push_back(Vec3d(0, 0, 0));
  std::vector<std::vector<int>> rings;
  for (int j = 1; j <= down; ++j)
  {
    const double polar = 0.5 * M_PI * j / down;
    rings.emplace_back();
    for (int k = 0; k < around; ++k)
    {
      const double a = 2.0 * M_PI * k / around;
      rings.back().push_back(int(m.vertices.size()));
      m.vertices.push_back(
          Vec3d(r * std::sin(polar) * std::cos(a), r * std::sin(polar) * std::sin(a), r - r * std::cos(polar)));
    }
  }
  rings.emplace_back();
  for (int k = 0; k < around; ++k)
  {
    const double a = 2.0 * M_PI * k / around;
    rings.back().push_back(int(m.vertices.size()));
    m.vertices.push_back(Vec3d(r * std::cos(a), r * std::sin(a), h));
  }
  const int lid = int(m.vertices.size());
  m.vertices.push_back(Vec3d(0, 0, h));
  for (int k = 0; k < around; ++k) m.triangles.push_back({0, rings[0][(k + 1) % around], rings[0][k]});
  for (std::size_t j = 0; j + 1 < rings.size(); ++j)
    for (int k = 0; k < around; ++k)
    {
      const auto& a = rings[j];
      const auto& b = rings[j + 1];
      m.triangles.push_back({a[k], a[(k + 1) % around], b[(k + 1) % around]});
      m.triangles.push_back({a[k], b[(k + 1) % around], b[k]});
    }
  for (int k = 0; k < around; ++k) m.triangles.push_back({lid, rings.back()[k], rings.back()[(k + 1) % around]});
  return m;
}

}  // namespace test
}  // namespace fluid_sim
