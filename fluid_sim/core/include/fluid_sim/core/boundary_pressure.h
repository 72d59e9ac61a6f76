#pragma once
// Pressure extrapolation to one boundary particle b from its fluid neighbours f (Eq. 3 and
// Eqs. 4-16 of docs/method.md).
// Both extrapolations are linear in the fluid pressures while positions are fixed:
//   p_b = constant_b + sum_f c_bf p_f,
// so the solver computes the coefficients once per step and each iteration is a sparse product
// (docs/method.md, "Extrapolation as coefficients"). These functions compute the coefficients for
// one boundary particle; boundary_pressure_methods.h applies them.

#include <Eigen/Eigenvalues>
#include <cmath>

#include "fluid_sim/core/scene_config.h"
#include "fluid_sim/core/types.h"

namespace fluid_sim
{
enum class MlsFit
{
  Empty,     // no fluid neighbour: p_b = 0 (all coefficients 0)
  Fallback,  // M_b singular: Eq. 16, p_b = alpha_b (weighted average)
  Reduced,   // pseudo-inverse: weak directions dropped, observable slopes kept
  Full       // Eqs. 14-15
};

/// MLS coefficients (paper Eqs. 7-16). `pos(k)` is x_f of neighbour k (m), `w[k]` = V_f W(x_b - x_f)
/// (the MLS weight; any positive scale), `scale` (m) normalises coordinates (the fit radius), so
/// the singularity test on the eigenvalue ratio of the normalised M_b is scale-free. Writes c[k].
template <class PosAt>
MlsFit mlsCoefficients(const Vec3& xb, int n, PosAt&& pos, const Real* w, double scale, double eigen_tolerance,
                       MlsSingularMode mode, Real* c)
{
  double wsum = 0.0;
  Vec3d d = Vec3d::Zero();
  for (int k = 0; k < n; ++k)
  {
    wsum += double(w[k]);
    d += double(w[k]) * pos(k).template cast<double>();
  }
  if (n == 0 || !(wsum > 0.0))
  {
    for (int k = 0; k < n; ++k) c[k] = Real(0);
    return MlsFit::Empty;
  }
  d /= wsum;  // Eq. 7: weighted centre d_b
  const double inv_scale = 1.0 / scale;
  // Normalised moment matrix M' = sum y y^T w / sum w with y = (x_f - d_b) / scale (Eqs. 8-10).
  Mat3d m = Mat3d::Zero();
  for (int k = 0; k < n; ++k)
  {
    const Vec3d y = (pos(k).template cast<double>() - d) * inv_scale;
    m.noalias() += (double(w[k]) / wsum) * (y * y.transpose());
  }
  const Vec3d yb = (xb.template cast<double>() - d) * inv_scale;  // Eq. 9: x̄_b, normalised
  Eigen::SelfAdjointEigenSolver<Mat3d> eig;
  eig.computeDirect(m);
  const Vec3d lambda = eig.eigenvalues();  // ascending
  const double lmax = lambda(2);
  MlsFit fit = MlsFit::Full;
  Vec3d q = Vec3d::Zero();  // q = M'^+ y_b, so that p_b = sum_f p_f (w_f / sum w)(1 + q . y_f)
  if (n < 4 || !(lmax > 1e-12))
    fit = MlsFit::Fallback;
  else if (mode == MlsSingularMode::Regularized)
  {
    // Eq. A20, Tikhonov-damped slopes: each direction weighted by lambda / (lambda^2 + (tol lambda_max)^2),
    // 1/lambda where it is well observed and going smoothly to 0 where it is not, so p_b changes
    // continuously as particles move (no switch between a fit and the fallback).
    const double tau2 = (eigen_tolerance * lmax) * (eigen_tolerance * lmax);
    const Mat3d& v = eig.eigenvectors();
    for (int e = 0; e < 3; ++e) q += v.col(e) * (v.col(e).dot(yb) * lambda(e) / (lambda(e) * lambda(e) + tau2));
    if (lambda(0) < eigen_tolerance * lmax) fit = MlsFit::Reduced;
  }
  else if (lambda(0) < eigen_tolerance * lmax)
    fit = mode == MlsSingularMode::Fallback ? MlsFit::Fallback : MlsFit::Reduced;
  if (fit != MlsFit::Fallback && mode != MlsSingularMode::Regularized)
  {
    const Mat3d& v = eig.eigenvectors();
    for (int e = 0; e < 3; ++e)
      if (lambda(e) >= eigen_tolerance * lmax) q += v.col(e) * (v.col(e).dot(yb) / lambda(e));
  }
  // alpha_b (Eq. 13) contributes w_f / sum w; the slope term (Eqs. 14-15) adds (q . y_f) w_f / sum w.
  for (int k = 0; k < n; ++k)
  {
    const Vec3d y = (pos(k).template cast<double>() - d) * inv_scale;
    c[k] = Real(double(w[k]) / wsum * (1.0 + q.dot(y)));
  }
  return fit;
}

/// SPH extrapolation (Adami 2012, paper Eq. 3): c[k] = W_k / sum W, and the hydrostatic constant
/// (g - a_b) . sum_f rho_f (x_b - x_f) W / sum W (Pa) returned through `constant`. `wk[k]` = W(x_b - x_f).
template <class PosAt, class RhoAt>
void sphCoefficients(const Vec3& xb, int n, PosAt&& pos, RhoAt&& rho, const Real* wk, const Vec3& g_minus_ab, Real* c,
                     Real& constant)
{
  double wsum = 0.0;
  Vec3d moment = Vec3d::Zero();
  for (int k = 0; k < n; ++k)
  {
    wsum += double(wk[k]);
    moment += double(rho(k)) * double(wk[k]) * (xb - pos(k)).template cast<double>();
  }
  if (n == 0 || !(wsum > 0.0))
  {
    for (int k = 0; k < n; ++k) c[k] = Real(0);
    constant = Real(0);
    return;
  }
  for (int k = 0; k < n; ++k) c[k] = Real(double(wk[k]) / wsum);
  constant = Real(g_minus_ab.template cast<double>().dot(moment) / wsum);
}

}  // namespace fluid_sim
