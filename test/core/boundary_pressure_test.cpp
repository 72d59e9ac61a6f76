#include "fluid_sim/core/boundary_pressure.h"

#include <gtest/gtest.h>

#include <functional>
#include <random>

#include "fluid_sim/core/bodies.h"
#include "fluid_sim/core/boundary_pressure_methods.h"
#include "fluid_sim/core/fluid_constants.h"
#include "fluid_sim/core/fluid_fill.h"
#include "fluid_sim/core/kernel.h"
#include "fluid_sim/core/neighborhoods.h"
#include "small_scene.h"

using namespace fluid_sim;

namespace
{
struct Neighbourhood
{
  std::vector<Vec3> x;
  std::vector<Real> w;    // V_f W
  std::vector<Real> wk;   // W
  std::vector<Real> rho;  // kg/m^3
};

/// Fluid neighbours of a boundary particle at xb: a jittered lattice within the radius; with
/// `half_empty` only those above the plane z = xb.z + s/4 (a wall beneath, as in a tank).
Neighbourhood neighbourhood(const Vec3& xb, Real s, Real radius, bool half_empty, unsigned seed)
{
  std::mt19937 rng(seed);
  std::uniform_real_distribution<Real> jitter(-Real(0.15) * s, Real(0.15) * s);
  const CubicKernel kernel(radius);
  Neighbourhood n;
  const int reach = int(std::ceil(radius / s));
  for (int k = -reach; k <= reach; ++k)
    for (int j = -reach; j <= reach; ++j)
      for (int i = -reach; i <= reach; ++i)
      {
        const Vec3 x = xb + Vec3(i * s + jitter(rng), j * s + jitter(rng), (k + Real(0.5)) * s + jitter(rng));
        if (half_empty && x.z() < xb.z() + Real(0.25) * s) continue;
        const Real W = kernel.W((xb - x).norm());
        if (W <= 0) continue;
        n.x.push_back(x);
        n.wk.push_back(W);
        n.rho.push_back(Real(1000) + Real(5) * jitter(rng) / s);
        n.w.push_back(s * s * s * Real(1000) / n.rho.back() * W);
      }
  return n;
}

Real extrapolateMls(const Vec3& xb, const Neighbourhood& n, const std::vector<Real>& p, Real radius, MlsFit* fit,
                    MlsSingularMode mode = MlsSingularMode::Fallback, double tol = 0.02)
{
  std::vector<Real> c(n.x.size());
  const MlsFit f = mlsCoefficients(
      xb, int(n.x.size()), [&](int k) { return n.x[k]; }, n.w.data(), radius, tol, mode, c.data());
  if (fit) *fit = f;
  double pb = 0;
  for (std::size_t k = 0; k < c.size(); ++k) pb += double(c[k]) * p[k];
  return Real(pb);
}
}  // namespace

TEST(MlsExtrapolation, ReproducesLinearFieldsToRoundOff)
{
  const Real s = Real(0.02);
  const Vec3 xb(Real(0.31), Real(-0.2), Real(0.05));
  const double tol = std::is_same<Real, float>::value ? 2e-4 : 1e-9;  // relative to the field's range
  for (Real radius : {2 * s, 3 * s})
    for (bool half : {false, true})
    {
      const Neighbourhood n = neighbourhood(xb, s, radius, half, 7);
      ASSERT_GT(n.x.size(), 8u) << "radius " << radius << " half " << half;
      // p(x) = p0 + G . (x - xb): hydrostatic-like plus tangential slopes.
      const Real p0 = 1234;
      const Vec3 G(Real(300), Real(-150), Real(-9810));
      std::vector<Real> p;
      for (const Vec3& x : n.x) p.push_back(p0 + G.dot(x - xb));
      MlsFit fit;
      const Real pb = extrapolateMls(xb, n, p, radius, &fit, MlsSingularMode::PseudoInverse, 1e-6);
      EXPECT_EQ(fit, MlsFit::Full) << "radius " << radius << " half " << half;
      const double range = G.norm() * radius;
      EXPECT_NEAR(pb, p0, tol * range) << "radius " << radius << " half-empty " << half;
    }
}

TEST(SphExtrapolation, ShowsItsDeficiencyErrorWhereMlsIsExact)
{
  // Half-empty neighbourhood, linear field without gravity term: the normalised average is the
  // pressure at the weighted centre, off by the slope times the centre's distance.
  const Real s = Real(0.02);
  const Vec3 xb(0, 0, 0);
  const Neighbourhood n = neighbourhood(xb, s, 2 * s, true, 3);
  const Vec3 G(0, 0, -9810);  // Pa/m
  std::vector<Real> p;
  for (const Vec3& x : n.x) p.push_back(Real(5000) + G.dot(x - xb));
  std::vector<Real> c(n.x.size());
  Real constant = 0;
  sphCoefficients(
      xb, int(n.x.size()), [&](int k) { return n.x[k]; }, [&](int k) { return n.rho[k]; }, n.wk.data(), Vec3::Zero(),
      c.data(), constant);
  double sph = constant;
  for (std::size_t k = 0; k < c.size(); ++k) sph += double(c[k]) * p[k];
  const Real mls = extrapolateMls(xb, n, p, 2 * s, nullptr, MlsSingularMode::PseudoInverse, 1e-6);
  const double sph_error = std::abs(sph - 5000.0), mls_error = std::abs(mls - 5000.0);
  // The normalised average of a linear field is its value at the W-weighted centre of the
  // neighbours, which lies most of a spacing above b: that is exactly the deficiency error.
  Vec3d centre = Vec3d::Zero();
  double wsum = 0.0;
  for (std::size_t k = 0; k < n.x.size(); ++k)
  {
    centre += double(n.wk[k]) * n.x[k].cast<double>();
    wsum += n.wk[k];
  }
  centre /= wsum;
  const double expected = std::abs(9810.0 * (centre.z() - xb.z()));
  EXPECT_NEAR(sph_error, expected, 1e-3 * expected);
  EXPECT_GT(sph_error, 0.25 * 9810 * s);
  EXPECT_LT(mls_error, 0.02 * sph_error);

  // With the hydrostatic term (Adami) and rho g matching the slope, SPH recovers most of it.
  sphCoefficients(
      xb, int(n.x.size()), [&](int k) { return n.x[k]; }, [&](int k) { return n.rho[k]; }, n.wk.data(),
      Vec3(0, 0, Real(-9.81)), c.data(), constant);
  double sph_g = constant;
  for (std::size_t k = 0; k < c.size(); ++k) sph_g += double(c[k]) * p[k];
  EXPECT_LT(std::abs(sph_g - 5000.0), 0.1 * sph_error);
}

TEST(MlsExtrapolation, SingularNeighbourhoodsFallBackWithoutNaN)
{
  const Real s = Real(0.02);
  const Vec3 xb(0, 0, 0);
  std::vector<std::vector<Vec3>> cases = {
      {Vec3(0, 0, s)},                                                                        // one neighbour
      {Vec3(0, 0, s), Vec3(s, 0, s), Vec3(2 * s, 0, s), Vec3(-s, 0, s), Vec3(-2 * s, 0, s)},  // collinear
      {},                                                                                     // coplanar (below)
  };
  for (int i = -1; i <= 1; ++i)
    for (int j = -1; j <= 1; ++j) cases[2].push_back(Vec3(i * s, j * s, s));
  for (std::size_t c = 0; c < cases.size(); ++c)
  {
    const auto& xs = cases[c];
    std::vector<Real> w, p, coef(xs.size());
    double wsum = 0, avg = 0;
    for (std::size_t k = 0; k < xs.size(); ++k)
    {
      w.push_back(Real(1e-6) * CubicKernel(2 * s).W(xs[k].norm()));
      p.push_back(Real(100 + 10 * k));
      wsum += w.back();
      avg += double(w.back()) * p.back();
    }
    avg /= wsum;
    const MlsFit fit = mlsCoefficients(
        xb, int(xs.size()), [&](int k) { return xs[k]; }, w.data(), 2 * s, 0.02, MlsSingularMode::Fallback,
        coef.data());
    EXPECT_EQ(fit, MlsFit::Fallback) << "case " << c;
    double pb = 0;
    for (std::size_t k = 0; k < xs.size(); ++k)
    {
      ASSERT_TRUE(std::isfinite(coef[k]));
      pb += double(coef[k]) * p[k];
    }
    EXPECT_NEAR(pb, avg, 1e-3 * avg) << "Eq. 16: the weighted average, case " << c;
  }
  // No neighbour at all: p_b = 0, no 0/0.
  Real dummy = 0;
  EXPECT_EQ(mlsCoefficients(
                xb, 0, [&](int) { return xb; }, &dummy, 2 * s, 0.02, MlsSingularMode::Fallback, &dummy),
            MlsFit::Empty);
}

TEST(MlsExtrapolation, PseudoInverseKeepsObservableSlopesOnACoplanarNeighbourhood)
{
  // Neighbours in the plane z = s: the normal slope is unobservable, the tangential ones are not.
  const Real s = Real(0.02);
  const Vec3 xb(Real(0.3) * s, 0, 0);
  std::vector<Vec3> xs;
  std::vector<Real> w, p;
  for (int i = -1; i <= 1; ++i)
    for (int j = -1; j <= 1; ++j)
    {
      xs.push_back(Vec3(i * s, j * s, s));
      w.push_back(CubicKernel(2 * s).W((xs.back() - xb).norm()));
      p.push_back(Real(1000) + Real(5000) * xs.back().x());  // slope along x only
    }
  std::vector<Real> coef(xs.size());
  const MlsFit fit = mlsCoefficients(
      xb, int(xs.size()), [&](int k) { return xs[k]; }, w.data(), 2 * s, 0.02, MlsSingularMode::PseudoInverse,
      coef.data());
  EXPECT_EQ(fit, MlsFit::Reduced);
  double pb = 0;
  for (std::size_t k = 0; k < xs.size(); ++k) pb += double(coef[k]) * p[k];
  EXPECT_NEAR(pb, 1000 + 5000 * xb.x(), 1e-2);
}

TEST(MlsExtrapolation, RegularizedSlopesAreDampedAndContinuousWhereTheFallbackJumps)
{
  // Eq. A20. A flat layer of neighbours above a wall particle, every other one lifted by a height
  // h: the wall-normal eigenvalue of the normalised moment matrix grows from 0 with h. The
  // fallback switches from the weighted mean to the full fit where the eigenvalue ratio crosses
  // tau, so p_b jumps there; the damped fit changes continuously, keeps sum_f c_bf = 1, and scales
  // the normal slope's contribution by exactly r^2 / (r^2 + tau^2), r = lambda_min / lambda_max.
  const Real s = Real(0.02), radius = 3 * s;  // a radius that keeps every lifted neighbour in reach
  const double tau = 0.1;
  const Vec3 xb(0, 0, 0);
  const CubicKernel kernel(radius);
  struct Layer
  {
    std::vector<Vec3> x;
    std::vector<Real> w;
  };
  auto layer = [&](Real h) {
    Layer l;
    for (int j = -1; j <= 1; ++j)
      for (int i = -1; i <= 1; ++i)
      {
        const Vec3 x(i * s, j * s, s + ((i + j) % 2 == 0 ? h : Real(0)));
        l.x.push_back(x);
        l.w.push_back(kernel.W(x.norm()));
      }
    return l;
  };
  const auto depth = [](const Vec3& x) { return double(1000 - 9810 * x.z()); };  // Pa, hydrostatic
  auto pb = [&](const Layer& l, MlsSingularMode mode, double tol, MlsFit* fit = nullptr, double* csum = nullptr) {
    std::vector<Real> c(l.x.size());
    const MlsFit f = mlsCoefficients(
        xb, int(l.x.size()), [&](int k) { return l.x[k]; }, l.w.data(), radius, tol, mode, c.data());
    if (fit) *fit = f;
    double sum = 0, value = 0;
    for (std::size_t k = 0; k < l.x.size(); ++k)
    {
      sum += c[k];
      value += double(c[k]) * depth(l.x[k]);
    }
    if (csum) *csum = sum;
    return value;
  };
  // Eigenvalue ratio of the normalised moment matrix (Eqs. 7-10 with coordinates / radius).
  auto ratio = [&](const Layer& l) {
    double wsum = 0;
    Vec3d d = Vec3d::Zero();
    for (std::size_t k = 0; k < l.x.size(); ++k)
    {
      wsum += l.w[k];
      d += double(l.w[k]) * l.x[k].cast<double>();
    }
    d /= wsum;
    Mat3d m = Mat3d::Zero();
    for (std::size_t k = 0; k < l.x.size(); ++k)
    {
      const Vec3d y = (l.x[k].cast<double>() - d) / double(radius);
      m += double(l.w[k]) / wsum * y * y.transpose();
    }
    const Vec3d lambda = Eigen::SelfAdjointEigenSolver<Mat3d>(m).eigenvalues();
    return lambda(0) / lambda(2);
  };
  double step_fallback = 0, step_damped = 0, prev_f = 0, prev_d = 0;
  bool switched = false;
  MlsFit prev_kind = MlsFit::Fallback;
  for (int k = 0; k <= 300; ++k)
  {
    const Layer l = layer(s * Real(k) / 300);  // lifts 0 .. s
    MlsFit kind;
    double csum = 0;
    const double f = pb(l, MlsSingularMode::Fallback, tau, &kind);
    const double d = pb(l, MlsSingularMode::Regularized, tau, nullptr, &csum);
    EXPECT_NEAR(csum, 1.0, 1e-5) << k;
    if (k > 0)
    {
      step_fallback = std::max(step_fallback, std::abs(f - prev_f));
      step_damped = std::max(step_damped, std::abs(d - prev_d));
      switched = switched || (prev_kind == MlsFit::Fallback && kind == MlsFit::Full);
    }
    prev_f = f;
    prev_d = d;
    prev_kind = kind;
    if (k % 50 == 25)
    {
      // Only the normal direction has a slope here (the lifted pattern is symmetric in x and y),
      // so the damped p_b lies between the mean and the full fit, at the damping factor.
      const double full = pb(l, MlsSingularMode::PseudoInverse, 1e-9);
      const double mean = pb(l, MlsSingularMode::Fallback, 1.0);  // always Eq. 16
      const double r = ratio(l);
      EXPECT_NEAR((d - mean) / (full - mean), r * r / (r * r + tau * tau), 1e-3) << "lift " << k << ", r " << r;
    }
  }
  EXPECT_TRUE(switched) << "the sweep should cross the fallback's threshold";
  EXPECT_GT(step_fallback, 10 * step_damped) << "fallback " << step_fallback << " Pa, damped " << step_damped << " Pa";
}

namespace
{
/// An extrapolation whose fit lists a test builds either way (the transpose of the fluid-boundary
/// lists, or a search of their own) for the same particles.
template <class Method>
struct FitListsProbe : Method
{
  using Method::Method;
  NeighborLists build(bool transpose)
  {
    this->findActive();
    if (transpose)
      this->transposeBoundaryLists();
    else
      this->searchFitLists();
    this->coefficients_.resize(this->fit_lists_.pairs());
    this->prepare();
    return this->fit_lists_;
  }
  std::vector<Real> coefficients() const
  {
    return this->coefficients_;
  }
};

template <class Method>
void expectTransposeEqualsSearch(BoundaryPressureMethod method)
{
  // Water in a tank, stirred so that the fluid is off its lattice and the rows are uneven.
  SceneConfig scene = test::waterTank(0.02, Vec3d(0.3, 0.2, 0.3), 0.12);
  scene.solver.boundary_pressure = method;
  const FluidConstants constants(scene);
  BodySet bodies(scene);
  FluidParticles fluid;
  fillFluid(scene, bodies, fluid);
  std::mt19937 rng(11);
  std::uniform_real_distribution<Real> jitter(Real(-0.006), Real(0.006));
  for (Vec3& x : fluid.x) x += Vec3(jitter(rng), jitter(rng), jitter(rng));
  Neighborhoods neighbors(scene, constants.kernel);
  neighbors.sortFluid(fluid);
  neighbors.build(fluid, bodies);
  ASSERT_GT(neighbors.fluid_boundary.pairs(), 1000u);
  const BoundaryPressureInputs in{scene, constants, fluid, bodies, neighbors};
  FitListsProbe<Method> searched(in), transposed(in);
  const NeighborLists a = searched.build(false), b = transposed.build(true);
  EXPECT_EQ(a.offset, b.offset);
  EXPECT_EQ(a.index, b.index);
  EXPECT_EQ(a.weight, b.weight);  // bit for bit: the same r^2 and the same kernel
  EXPECT_EQ(searched.coefficients(), transposed.coefficients());
  // The diagonal's feedback (Eq. A4b) reads c_bi through the transpose's map or by bisection.
  std::size_t with_feedback = 0;
  for (std::size_t i = 0; i < fluid.size(); ++i)
  {
    const Vec3 fa = searched.feedbackVector(i, fluid.x[i]), fb = transposed.feedbackVector(i, fluid.x[i]);
    EXPECT_EQ(fa, fb) << "fluid particle " << i;
    with_feedback += fa != Vec3::Zero();
  }
  EXPECT_GT(with_feedback, fluid.size() / 10);
}
}  // namespace

TEST(ExtrapolationFitLists, TheTransposeOfTheBoundaryListsEqualsTheFitsOwnSearch)
{
  expectTransposeEqualsSearch<MlsBoundaryPressure>(BoundaryPressureMethod::Mls);
  expectTransposeEqualsSearch<SphBoundaryPressure>(BoundaryPressureMethod::SphExtrapolation);
}
