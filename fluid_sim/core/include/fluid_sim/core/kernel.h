#pragma once
// Cubic spline kernel (Monaghan 2005) in 3D, written with the support radius h (W = 0 for r >= h).
// Eq. A18 of docs/method.md: h = 2 x spacing.

#include <cmath>

#include "fluid_sim/core/types.h"

namespace fluid_sim
{
class CubicKernel
{
public:
  explicit CubicKernel(Real support) : h_(support), inv_h_(Real(1) / support)
  {
    const Real h3 = support * support * support;
    k_ = Real(8.0 / M_PI) / h3;   // 1/m^3: normalisation of W
    l_ = Real(48.0 / M_PI) / h3;  // 1/m^3: normalisation of dW/dq
    w_zero_ = k_;
  }

  Real support() const
  {
    return h_;
  }

  /// W(r), 1/m^3.
  Real W(Real r) const
  {
    // Both pieces, then selects: neighbour distances are random to the branch predictor, and
    // these run once per pair per step.
    const Real q = r * inv_h_;
    const Real a = Real(1) - q;
    const Real inner = k_ * (Real(6) * q * q * (q - Real(1)) + Real(1));
    const Real outer = k_ * Real(2) * a * a * a;
    const Real w = q <= Real(0.5) ? inner : outer;
    return q < Real(1) ? w : Real(0);
  }
  Real W(const Vec3& r) const
  {
    return W(r.norm());
  }
  Real W0() const
  {
    return w_zero_;
  }

  /// Gradient of W with respect to the first particle, r = x_i - x_j; 1/m^4.
  Vec3 gradW(const Vec3& r) const
  {
    const Real rl2 = r.squaredNorm();
    if (rl2 >= h_ * h_ || rl2 < Real(1e-18) * h_ * h_) return Vec3::Zero();
    const Real rl = std::sqrt(rl2);
    const Real q = rl * inv_h_;
    const Real factor = q <= Real(0.5) ? l_ * q * (Real(3) * q - Real(2)) : -l_ * (Real(1) - q) * (Real(1) - q);
    // dW/dr = factor / h; direction r / |r|.
    return r * (factor * inv_h_ / rl);
  }

  /// (dW/dr) / r for 0 < r < h (0 outside), 1/m^5: grad W(r_vec) = gradFactor(|r|) * r_vec. The
  /// neighbour lists store this scalar per pair instead of a vector.
  Real gradFactor(Real r) const
  {
    // Branch-free like W(). At r = 0 `outer` is infinite but never selected.
    const Real q = r * inv_h_;
    const Real a = Real(1) - q;
    const Real inner = l_ * (Real(3) * q - Real(2)) * inv_h_ * inv_h_;  // l q (3q - 2) / (h r), q / r = 1 / h
    const Real outer = -l_ * a * a * inv_h_ / r;
    const Real f = q <= Real(0.5) ? inner : outer;
    return (q < Real(1) && r > Real(0)) ? f : Real(0);
  }

private:
  Real h_, inv_h_, k_, l_, w_zero_;
};

}  // namespace fluid_sim
