#include "fluid_sim/core/kernel.h"

#include <gtest/gtest.h>

using namespace fluid_sim;

TEST(Kernel, IntegratesToOneOverFineLattice)
{
  const Real h = Real(0.04);
  const CubicKernel kernel(h);
  const double dx = h / 40.0;
  double sum = 0.0;
  const int n = 41;
  for (int k = -n; k <= n; ++k)
    for (int j = -n; j <= n; ++j)
      for (int i = -n; i <= n; ++i) sum += kernel.W(Real(dx * std::sqrt(double(i * i + j * j + k * k))));
  EXPECT_NEAR(sum * dx * dx * dx, 1.0, 1e-3);
}

TEST(Kernel, ParticleLatticeAtHalfSupportGivesRestDensity)
{
  // h = 2 s (docs/method.md, Eq. A18): a cubic lattice of spacing s sums s^3 W to one, so a fluid lattice
  // starts at rest density.
  const Real s = Real(0.02);
  const CubicKernel kernel(2 * s);
  double sum = 0.0;
  for (int k = -2; k <= 2; ++k)
    for (int j = -2; j <= 2; ++j)
      for (int i = -2; i <= 2; ++i) sum += kernel.W(Vec3(i * s, j * s, k * s));
  EXPECT_NEAR(sum * s * s * s, 1.0, 2e-3);
}

TEST(Kernel, GradientsSumToZeroInsideAndMatchFiniteDifferences)
{
  const Real s = Real(0.02);
  const CubicKernel kernel(2 * s);
  Vec3 g = Vec3::Zero();
  for (int k = -2; k <= 2; ++k)
    for (int j = -2; j <= 2; ++j)
      for (int i = -2; i <= 2; ++i)
        g += kernel.gradW(Vec3(i * s + Real(0.003), j * s - Real(0.002), k * s + Real(0.001)) -
                          Vec3(Real(0.003), Real(-0.002), Real(0.001)));
  EXPECT_LT(g.norm(), 1e-3 * kernel.gradW(Vec3(s, 0, 0)).norm());

  for (Real r : {Real(0.003), Real(0.012), Real(0.021), Real(0.033)})
  {
    const Vec3 x(r * Real(0.6), r * Real(0.8), 0);
    const Vec3 grad = kernel.gradW(x);
    const Real e = Real(1e-5);
    for (int a = 0; a < 3; ++a)
    {
      Vec3 dp = x, dm = x;
      dp[a] += e;
      dm[a] -= e;
      const Real fd = (kernel.W(dp) - kernel.W(dm)) / (2 * e);
      EXPECT_NEAR(grad[a], fd, 2e-3 * std::abs(kernel.gradW(Vec3(s, 0, 0)).x()) + 1e-3 * std::abs(fd));
    }
  }
}

TEST(Kernel, CompactSupport)
{
  const CubicKernel kernel(Real(0.04));
  EXPECT_EQ(kernel.W(Real(0.04)), 0);
  EXPECT_EQ(kernel.W(Real(0.05)), 0);
  EXPECT_GT(kernel.W(Real(0.0399)), 0);
  EXPECT_EQ(kernel.gradW(Vec3(0.04, 0, 0)).norm(), 0);
  EXPECT_EQ(kernel.gradW(Vec3(0, 0, 0)).norm(), 0);
  EXPECT_GT(kernel.W(Real(0)), kernel.W(Real(0.01)));
}

TEST(Kernel, GradientFactorMatchesGradient)
{
  const CubicKernel kernel(Real(0.04));
  for (Real r : {Real(0.001), Real(0.015), Real(0.02), Real(0.025), Real(0.0399), Real(0.04), Real(0.05)})
  {
    const Vec3 x(r * Real(0.36), r * Real(0.48), r * Real(0.8));
    const Vec3 expected = kernel.gradW(x);
    EXPECT_LT((kernel.gradFactor(x.norm()) * x - expected).norm(), 1e-5 * (expected.norm() + 1)) << r;
  }
}
