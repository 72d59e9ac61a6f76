// Physical checks against exact answers: hydrostatic pressure, the floor force equal to the
// water's weight, Archimedes' buoyancy on a fixed submerged cube, and a block at rest staying at
// rest. Small scenes (spacing 2 cm) so that the whole file runs in well under a minute.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "fluid_sim/core/simulation.h"

using namespace fluid_sim;

namespace
{
constexpr double kG = 9.81;

SceneConfig column(BoundaryPressureMethod method, double width, double depth, double spacing = 0.02)
{
  SceneConfig s;
  s.spacing = spacing;
  s.domain = {Vec3d(-0.1, -0.1, -0.1), Vec3d(width + 0.1, width + 0.1, depth + 0.3)};
  s.time_step.fixed = 0.001;
  s.solver.boundary_pressure = method;
  s.viscosity.model = ViscosityModel::Xsph;
  s.viscosity.coefficient = 0.01;
  FluidBlockConfig f;
  f.box = {Vec3d(0, 0, 0), Vec3d(width, width, depth)};
  s.fluid.push_back(f);
  BoundaryConfig tank;
  tank.name = "tank";
  tank.type = ShapeType::Box;
  tank.box = {Vec3d(0, 0, 0), Vec3d(width, width, depth + 0.2)};
  tank.inside = true;
  s.boundaries.push_back(tank);
  return s;
}

struct Averages
{
  std::vector<double> pressure, exact;  // per depth bin, Pa
  Vec3d tank_force = Vec3d::Zero();     // N, world
  Vec3d body_force = Vec3d::Zero();     // N, world (second body, if any)
  double max_speed = 0.0;               // m/s, over the averaging window
  double water_height = 0.0;            // m
};

/// Runs `settle` s, then averages over `window` s: pressure by depth bins of one spacing, forces.
Averages settleAndAverage(Simulation& sim, double settle, double window, double area)
{
  const SceneConfig& sc = sim.scene();
  const double s = sc.spacing;
  Averages out;
  out.water_height = sim.numFluidParticles() * s * s * s / area;
  const int bins = int(std::round(out.water_height / s));
  out.pressure.assign(bins, 0.0);
  out.exact.assign(bins, 0.0);
  std::vector<int> count(bins, 0);
  int steps = 0;
  while (sim.time() < settle + window - 1e-9)
  {
    const StepReport r = sim.step();
    EXPECT_FALSE(r.unstable) << r.reason;
    if (r.unstable) break;
    if (sim.time() <= settle) continue;
    ++steps;
    out.max_speed = std::max(out.max_speed, r.max_speed);
    out.tank_force += sim.body(0).force;
    if (sim.numBodies() > 1) out.body_force += sim.body(1).force;
    for (std::size_t i = 0; i < sim.numFluidParticles(); ++i)
    {
      const double d = out.water_height - sim.positions()[i].z();
      const int b = int(std::floor(d / s));
      if (b < 0 || b >= bins) continue;
      out.pressure[b] += sim.pressures()[i];
      out.exact[b] += sc.rest_density * kG * d;
      ++count[b];
    }
  }
  for (int b = 0; b < bins; ++b)
    if (count[b])
    {
      out.pressure[b] /= count[b];
      out.exact[b] /= count[b];
    }
  if (steps)
  {
    out.tank_force /= steps;
    out.body_force /= steps;
  }
  return out;
}

class Hydrostatics : public ::testing::TestWithParam<BoundaryPressureMethod>
{
};
class PressureProfile : public Hydrostatics
{
};
class Buoyancy : public Hydrostatics
{
};
class Rest : public Hydrostatics
{
};

std::string methodName(const ::testing::TestParamInfo<BoundaryPressureMethod>& info)
{
  return toString(info.param);
}
}  // namespace

TEST_P(Hydrostatics, TankForceEqualsWaterWeight)
{
  const double width = 0.2, depth = 0.4;
  Simulation sim(column(GetParam(), width, depth));
  ASSERT_EQ(sim.numFluidParticles(), 10u * 10u * 20u);
  const double weight = sim.numFluidParticles() * sim.particleMass() * kG;
  const Averages avg = settleAndAverage(sim, 0.6, 0.4, width * width);
  // The fluid pushes the floor down with its weight; no net sideways force.
  EXPECT_NEAR(avg.tank_force.z() / -weight, 1.0, 0.02)
      << toString(GetParam()) << ": max speed in the window " << avg.max_speed << " m/s";
  EXPECT_NEAR(avg.tank_force.x() / weight, 0.0, 0.02);
  EXPECT_NEAR(avg.tank_force.y() / weight, 0.0, 0.02);
  EXPECT_EQ(sim.numFluidParticles(), 2000u);
  EXPECT_EQ(sim.removedTotal(), 0u);
}

TEST_P(PressureProfile, PressureIsRhoGDepth)
{
  const double width = 0.2, depth = 0.4;
  Simulation sim(column(GetParam(), width, depth));
  const Averages avg = settleAndAverage(sim, 0.6, 0.4, width * width);
  // Time-averaged pressure at depth d is rho0 g d below the first two layers (the floor's layer
  // excluded). One step's pressure is noisy at a 0.1 % density tolerance; its mean is not.
  for (std::size_t b = 2; b + 1 < avg.pressure.size(); ++b)
    EXPECT_NEAR(avg.pressure[b] / avg.exact[b], 1.0, 0.05)
        << toString(GetParam()) << ": depth " << (b + 0.5) * 0.02 << " m, p " << avg.pressure[b] << " Pa, exact "
        << avg.exact[b] << " Pa";
}

TEST_P(Buoyancy, SubmergedCubeFeelsArchimedesForce)
{
  // A 0.1 m cube, 7 spacings a side (at 5 spacings the error is -5.8 % for mls and +5.2 % for
  // sph; see docs/method_notes.md), its faces on the fluid lattice, 4 spacings from the tank's
  // side walls and 6 above its floor, 9 under the surface: a 0.21 x 0.21 m tank, 0.31 m deep
  // (4,607 particles). The validation suite (case 7) runs the same cube in a tank twice as wide
  // and 1.3 times as deep. Measured in 0.2 s windows from 0.4 to 2 s (docs/method_notes.md):
  // mls 1.004-1.022, sph 0.990-1.011 (the wider tank: mls 0.998 over 1.8-2.0 s); the water
  // around the cube has rearranged by 0.6 s.
  const double s = 0.1 / 7.0, width = 15 * s, depth = 22 * s, side = 7 * s;
  SceneConfig scene = column(GetParam(), width, depth, s);
  BoundaryConfig cube;
  cube.name = "cube";
  cube.type = ShapeType::Box;
  cube.box = {Vec3d(4 * s, 4 * s, 6 * s), Vec3d(11 * s, 11 * s, 13 * s)};
  scene.boundaries.push_back(cube);
  Simulation sim(scene);
  EXPECT_EQ(sim.removedAtStart(), 343u);  // the 7^3 lattice points inside the cube
  const Averages avg = settleAndAverage(sim, 0.6, 0.4, width * width - side * side);
  const double archimedes = 1000.0 * kG * side * side * side;
  std::printf("%s: cube force / (rho0 g V) = %.4f\n", toString(GetParam()), avg.body_force.z() / archimedes);
  EXPECT_NEAR(avg.body_force.z() / archimedes, 1.0, 0.05) << toString(GetParam()) << ": " << avg.body_force.transpose();
  EXPECT_NEAR(avg.body_force.x() / archimedes, 0.0, 0.05);
  EXPECT_NEAR(avg.body_force.y() / archimedes, 0.0, 0.05);
}

TEST_P(Rest, BlockAtRestComesToRest)
{
  // A 0.2 m block starts without pressure and compresses under its weight; the start-up
  // transient (max speeds ~0.07 m/s) must decay, not grow. sqrt(g H) = 1.4 m/s is the speed scale
  // of any motion the column could start.
  // The late maximum is one particle slipping through a rearrangement of the lattice inside the
  // water (seen at 4 cm depth, 3 cm/s for 70 ms), so its value depends on rounding: over
  // dt 0.9-1.1 ms and equivalent rewrites of the solver loops it ranged 0.021-0.056 m/s (sph)
  // and 0.021-0.047 m/s (mls) while the rms speed stayed 3.5-5.5 mm/s and the 99th percentile
  // 1.4-2.2 cm/s. A failure just above 0.05 after a change that only reorders floating-point
  // operations is that spread, not a new instability; a growing rms is.
  // So the bound of 0.05 m/s is on the 99th percentile of the speeds after 2.5 s (the fastest 1 %
  // may hold the slipping particle), not on the single fastest particle: on an AVX-512 machine
  // the same code's single maximum was 0.066 m/s (mls) where it had been 0.047 m/s elsewhere,
  // and the test failed on main unchanged. There the 99th percentile was 0.020 (mirroring),
  // 0.020 (sph) and 0.029 m/s (mls). The rms decay below is what says the water comes to rest.
  Simulation sim(column(GetParam(), 0.2, 0.2));
  const std::size_t n = sim.numFluidParticles();
  double peak_rms = 0.0, late_max = 0.0, late_p99 = 0.0, rms = 0.0;
  std::vector<double> speeds;
  while (sim.time() < 3.0 - 1e-9)
  {
    const StepReport r = sim.step();
    ASSERT_FALSE(r.unstable) << r.reason;
    double ke = 0.0;
    for (const Vec3& v : sim.velocities()) ke += v.squaredNorm();
    rms = std::sqrt(ke / sim.numFluidParticles());
    peak_rms = std::max(peak_rms, rms);
    if (sim.time() > 2.5)
    {
      late_max = std::max(late_max, r.max_speed);
      speeds.clear();
      for (const Vec3& v : sim.velocities()) speeds.push_back(v.norm());
      const auto p99 = speeds.begin() + std::ptrdiff_t(0.99 * double(speeds.size()));
      std::nth_element(speeds.begin(), p99, speeds.end());
      late_p99 = std::max(late_p99, *p99);
    }
  }
  std::printf(
      "%s: after 2.5 s max speed %.4f m/s, 99th percentile %.4f m/s; rms speed %.4f m/s at 3 s, start-up "
      "peak %.4f m/s\n",
      toString(GetParam()), late_max, late_p99, rms, peak_rms);
  EXPECT_LT(late_p99, 0.05) << toString(GetParam());
  // The single fastest particle: 0.066 m/s (mls) on that machine; twice 0.05 says nothing was thrown.
  EXPECT_LT(late_max, 0.1) << toString(GetParam());
  EXPECT_LT(rms, peak_rms / 3) << toString(GetParam()) << ": rms speed " << rms << " m/s, start-up peak " << peak_rms;
  EXPECT_EQ(sim.numFluidParticles(), n);
}

class WallWork : public Hydrostatics
{
};

TEST_P(WallWork, BoundaryPressureTermWork)
{
  // The p_b part of the wall term, -psi_b (p_b/rho0^2) grad W_ib, is the gradient of a potential
  // while p_b is a fixed field on the wall: sph and mls extrapolate one p_b per boundary particle,
  // and near rest that field stands still, so over 1.5 s the term does almost no net work
  // (measured |W| <= 0.03 J, 0.2 % of m g H). Mirroring gives each fluid particle its own p_b = p_i;
  // along a vertical wall p_i grows with depth, the term has a curl and drives a circulation
  // (down the walls, up the middle) that it keeps feeding: measured W = 5.2-5.9 J by 1.5 s
  // against 0.4-0.45 J of kinetic energy left in the water. That is why the mirroring Rest test cannot pass
  // (docs/method_notes.md). If this part ever fails for mirroring, the mirroring tests below
  // deserve another run.
  Simulation sim(column(GetParam(), 0.2, 0.2));
  const double mgh = sim.numFluidParticles() * sim.particleMass() * kG * 0.2;  // J
  double work = 0.0, ke = 0.0;
  while (sim.time() < 1.5 - 1e-9)
  {
    const StepReport r = sim.step();
    ASSERT_FALSE(r.unstable) << r.reason;
    work += r.boundary_pressure_work;
    ke = r.kinetic_energy;
  }
  if (GetParam() == BoundaryPressureMethod::MirroringEq2)
  {
    EXPECT_GT(work, 0.1 * mgh) << "mirroring_eq2: W " << work << " J, m g H " << mgh << " J";
    EXPECT_GT(work, 3.0 * ke) << "mirroring_eq2: W " << work << " J, kinetic energy " << ke << " J";
  }
  else
    EXPECT_LT(std::abs(work), 0.005 * mgh) << toString(GetParam()) << ": W " << work << " J, m g H " << mgh << " J";
}

const auto kAll = ::testing::Values(BoundaryPressureMethod::Mirroring, BoundaryPressureMethod::MirroringEq2,
                                    BoundaryPressureMethod::SphExtrapolation, BoundaryPressureMethod::Mls);
// The methods that bring water to rest: single-term mirroring and the two extrapolations.
const auto kResting = ::testing::Values(BoundaryPressureMethod::Mirroring, BoundaryPressureMethod::SphExtrapolation,
                                        BoundaryPressureMethod::Mls);
INSTANTIATE_TEST_SUITE_P(Resting, Hydrostatics, kResting, methodName);
INSTANTIATE_TEST_SUITE_P(Extrapolated, PressureProfile,
                         ::testing::Values(BoundaryPressureMethod::SphExtrapolation, BoundaryPressureMethod::Mls),
                         methodName);
// Known failure: with single-term mirroring the water comes to rest and the tank carries its
// weight, but the time-averaged pressure reads 6 % (at 9 cm) to 19 % (at 27 cm) above rho0 g d.
INSTANTIATE_TEST_SUITE_P(DISABLED_Mirroring, PressureProfile, ::testing::Values(BoundaryPressureMethod::Mirroring),
                         methodName);
INSTANTIATE_TEST_SUITE_P(Extrapolated, Buoyancy,
                         ::testing::Values(BoundaryPressureMethod::SphExtrapolation, BoundaryPressureMethod::Mls),
                         methodName);
// Known failure: single-term mirroring's cube feels 0.943 rho0 g V here (0.926 in validation
// case 7's wider tank). It follows the boundary volume factor gamma of Eq. A3 (0.85: 1.035,
// 1 (Akinci's): 1.071), which the extrapolations barely feel (docs/method_notes.md); not fixed.
INSTANTIATE_TEST_SUITE_P(DISABLED_Mirroring, Buoyancy, ::testing::Values(BoundaryPressureMethod::Mirroring),
                         methodName);
INSTANTIATE_TEST_SUITE_P(Resting, Rest, kResting, methodName);
INSTANTIATE_TEST_SUITE_P(AllMethods, WallWork, kAll, methodName);
// Known failures, kept runnable (--gtest_also_run_disabled_tests): with the paper's mirroring
// (Eq. 2, mirroring_eq2) the water in the box does not come to rest (rms speed grows to 0.37 m/s
// in 3 s where the others decay to 0.004-0.006 m/s), its time-averaged pressure is ~15 % above
// rho0 g d and the cube's buoyancy +22 % at 7 spacings a side. The cause, the mirrored p_b term's
// work, is what WallWork.BoundaryPressureTermWork measures (docs/method_notes.md).
// The floor force equals the weight only when the water's momentum is steady: with Eq. 2 the
// 0.4 m column sloshes at up to 6 m/s in the averaging window, and the ratio was 1.002 or 1.023
// depending on nothing but the particle order of the neighbour grid.
const auto kEq2 = ::testing::Values(BoundaryPressureMethod::MirroringEq2);
INSTANTIATE_TEST_SUITE_P(DISABLED_MirroringEq2, Hydrostatics, kEq2, methodName);
INSTANTIATE_TEST_SUITE_P(DISABLED_MirroringEq2, PressureProfile, kEq2, methodName);
INSTANTIATE_TEST_SUITE_P(DISABLED_MirroringEq2, Buoyancy, kEq2, methodName);
INSTANTIATE_TEST_SUITE_P(DISABLED_MirroringEq2, Rest, kEq2, methodName);
