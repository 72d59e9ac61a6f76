// Budgets (issue 12): work a scene asks for is refused before anything large is allocated, with
// the number in the message; what is merely spread out (two small triangles far apart) costs
// memory by its particles, not by its bounding box.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "fluid_sim/core/boundary_sampling.h"
#include "fluid_sim/core/kernel.h"
#include "fluid_sim/core/scene_config.h"
#include "fluid_sim/core/simulation.h"

#include "small_scene.h"

namespace fluid_sim
{
namespace
{
using test::smallScene;

/// validate()'s error as "key: message", or "" if there is none.
std::string errorOf(const SceneConfig& s)
{
  try
  {
    validate(s);
  }
  catch (const ConfigError& e)
  {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(Budget, FluidParticlesAreCountedBeforeTheLatticeIsMade)
{
  // A domain the grid check allows (5.5e2^3 cells of 2 spacings), filled at 1 mm: 1.33e9 lattice
  // points, about 100 GB of particle state, refused by validate() before the fill.
  SceneConfig s = smallScene();
  s.spacing = 0.001;
  s.domain = {Vec3d(0, 0, 0), Vec3d(1.1, 1.1, 1.1)};
  s.fluid[0].box = s.domain;
  const std::string e = errorOf(s);
  EXPECT_NE(e.find("fluid: "), std::string::npos) << e;
  EXPECT_NE(e.find("1.331e+09 fluid particles"), std::string::npos) << e;
  EXPECT_NE(e.find("max_fluid_particles = 20000000"), std::string::npos) << e;

  // The budget is a scene key; the default admits the shipped scenes (at most 1e6 particles).
  s.max_fluid_particles = 2000000000;
  EXPECT_EQ(errorOf(s), "");
  SceneConfig small = smallScene();  // 4 x 4 x 4 lattice points
  small.max_fluid_particles = 63;
  EXPECT_NE(errorOf(small).find("64 fluid particles"), std::string::npos) << errorOf(small);
  small.max_fluid_particles = 64;
  EXPECT_EQ(errorOf(small), "");
}

TEST(Budget, IterationAndTimeStepLimits)
{
  SceneConfig s = smallScene();
  s.solver.max_iterations = 1000000;
  EXPECT_NE(errorOf(s).find("solver.max_iterations: must be <= 10000, got 1000000"), std::string::npos) << errorOf(s);
  s = smallScene();
  s.solver.max_iterations = 10000;
  s.solver.min_iterations = 20000;
  EXPECT_NE(errorOf(s).find("solver.min_iterations: must be <= 10000, got 20000"), std::string::npos) << errorOf(s);
  s = smallScene();
  s.solver.max_iterations = 10000;
  s.solver.min_iterations = 10000;
  EXPECT_EQ(errorOf(s), "");
  // Chebyshev's radius (Eq. A8a) below 1 (at 1 its weights grow without bound), its delay >= 1
  // (the first extrapolated sweep needs the sweep before).
  s = smallScene();
  s.solver.chebyshev_rho = 1.0;
  EXPECT_NE(errorOf(s).find("solver.chebyshev_rho: must be in [0, 1) (0 = off), got 1"), std::string::npos)
      << errorOf(s);
  s.solver.chebyshev_rho = 0.0;
  EXPECT_EQ(errorOf(s), "");
  s.solver.chebyshev_delay = 0;
  EXPECT_NE(errorOf(s).find("solver.chebyshev_delay: must be in [1, 10000], got 0"), std::string::npos) << errorOf(s);

  s = smallScene();
  s.time_step.adaptive = true;
  s.time_step.min = 1e-300;  // a run that never gets anywhere
  EXPECT_NE(errorOf(s).find("time_step.min: must be in [1e-07, 1] s, got 1e-300"), std::string::npos) << errorOf(s);
  s.time_step.min = 1e-5;
  s.time_step.max = 100.0;
  EXPECT_NE(errorOf(s).find("time_step.max: must be <= 1 s"), std::string::npos) << errorOf(s);
  s = smallScene();
  s.time_step.fixed = 1e-12;
  EXPECT_NE(errorOf(s).find("time_step.fixed: must be in [1e-07, 0.1] s, got 1e-12"), std::string::npos) << errorOf(s);
  // One range in every message: 0.5 s said "<= 0.1 s", 2 s "in [1e-07, 1] s".
  for (double dt : {0.5, 2.0})
  {
    s.time_step.fixed = dt;
    EXPECT_NE(errorOf(s).find("time_step.fixed: must be in [1e-07, 0.1] s, got"), std::string::npos) << errorOf(s);
  }
  s.time_step.fixed = 0.1;
  EXPECT_EQ(errorOf(s), "");
  // An adaptive step at max_cfl trips the stability check once the speed grows within it (a
  // water block falling freely was stopped as unstable at 0.41 s with cfl 2).
  s = smallScene();
  s.time_step.adaptive = true;
  s.time_step.cfl = 2.0;
  EXPECT_NE(errorOf(s).find("time_step.cfl: must be below stability.max_cfl (2), got 2"), std::string::npos)
      << errorOf(s);
  s.stability.max_cfl = 4.0;
  EXPECT_EQ(errorOf(s), "");
  // A bad XSPH boundary coefficient is named as itself (it was reported as viscosity.coefficient).
  s = smallScene();
  s.viscosity.model = ViscosityModel::Xsph;
  s.viscosity.coefficient = 0.1;
  s.viscosity.boundary = 2.0;
  EXPECT_NE(errorOf(s).find("viscosity.boundary: XSPH coefficients must be <= 1, got 2"), std::string::npos)
      << errorOf(s);
  s.viscosity.boundary = 0.1;
  s.viscosity.coefficient = 1.5;
  EXPECT_NE(errorOf(s).find("viscosity.coefficient: XSPH coefficients must be <= 1, got 1.5"), std::string::npos)
      << errorOf(s);
}

TEST(Budget, BoundaryVolumesCostMemoryByParticlesNotByTheirBoundingBox)
{
  // Two clusters 100 m apart on every axis: a dense grid of kernel-support cells over their
  // bounding box (2500^3 cells at a 4 cm support) asked for 62 GB.
  const double support = 0.04;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 0.1);
  std::vector<Vec3d> a, b;
  for (int k = 0; k < 300; ++k) a.emplace_back(u(rng), u(rng), u(rng));
  for (int k = 0; k < 300; ++k) b.emplace_back(Vec3d(100, 100, 100) + Vec3d(u(rng), u(rng), u(rng)));
  std::vector<Vec3d> both = a;
  both.insert(both.end(), b.begin(), b.end());
  const std::vector<Real> v = boundaryVolumes(both, support, 1.0);
  ASSERT_EQ(v.size(), both.size());

  // Each volume is 1 / sum of W over the points within the support, brute force in any order;
  // distances in Real from the bounding box centre, as the simulation stores positions.
  Vec3d lo = both[0], hi = both[0];
  for (const Vec3d& p : both)
  {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Vec3d centre = 0.5 * (lo + hi);
  const CubicKernel kernel{Real(support)};
  for (std::size_t i = 0; i < both.size(); ++i)
  {
    const Vec3 xi = (both[i] - centre).cast<Real>();
    double sum = 0.0;
    for (std::size_t k = 0; k < both.size(); ++k)
    {
      const Real d2 = (xi - (both[k] - centre).cast<Real>()).squaredNorm();
      if (d2 < Real(support * support)) sum += kernel.W(std::sqrt(d2));
    }
    ASSERT_NEAR(v[i] * sum, 1.0, 1e-6) << i;
  }
}

TEST(Budget, TwoSmallTrianglesFarApartMakeABody)
{
  // At 2 cm (a 4 cm kernel support) the dense grid over these two triangles was 62 GB.
  SceneConfig s = smallScene();
  s.spacing = 0.02;
  BoundaryConfig plates;
  plates.name = "plates";
  plates.type = ShapeType::Mesh;
  plates.mesh.vertices = {Vec3d(0.3, 0.3, 0.3),       Vec3d(0.4, 0.3, 0.3),       Vec3d(0.3, 0.4, 0.3),
                          Vec3d(100.3, 100.3, 100.3), Vec3d(100.4, 100.3, 100.3), Vec3d(100.3, 100.4, 100.3)};
  plates.mesh.triangles = {{0, 1, 2}, {3, 4, 5}};
  plates.mesh_closed = false;
  s.boundaries.push_back(plates);
  s.fill.relax = false;
  Simulation sim(s);
  EXPECT_GT(sim.boundaryPositions().size(), 2u);
  for (std::size_t k = 0; k < 5; ++k) EXPECT_FALSE(sim.step().unstable);
}

}  // namespace fluid_sim
