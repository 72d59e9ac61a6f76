// Gravity and viscosity (see non_pressure_forces.h). Equation numbers refer to docs/method.md.

#include "fluid_sim/core/non_pressure_forces.h"

#include <algorithm>

#include "fluid_sim/core/parallel.h"

namespace fluid_sim
{
namespace
{
/// Eq. A13, one pair: the artificial-viscosity acceleration of i from j (or from a boundary
/// particle), coefficient nu (m^2/s), neighbour volume (m^3), r = x_i - x_j (m), v_ij (m/s),
/// grad_factor (1/m^5), eps = 0.01 h^2 (m^2). 2(d + 2) = 10 in three dimensions.
inline Vec3 artificialViscosity(Real nu, Real volume, const Vec3& r, const Vec3& vij, Real grad_factor, Real eps)
{
  return (Real(10) * nu * volume * vij.dot(r) / (r.squaredNorm() + eps) * grad_factor) * r;
}
}  // namespace

NonPressureForces::NonPressureForces(const ViscosityConfig& viscosity, const FluidConstants& constants)
    : viscosity_(viscosity), constants_(constants)
{
}

void NonPressureForces::apply(double dt, FluidParticles& fluid, const Neighborhoods& neighbors, const BodySet& bodies,
                              BodyWrenches& wrenches, ForceScratch scratch)
{
  const std::size_t n = fluid.size();
  const Real dtr = Real(dt);
  const Vec3 gravity = constants_.gravity;
  std::vector<Vec3>& v = fluid.v;
  const ViscosityConfig& visc = viscosity_;
  if (visc.model == ViscosityModel::None || (visc.coefficient == 0.0 && visc.boundary == 0.0))
  {
    parallelFor(n, [&](std::size_t i) { v[i] += dtr * gravity; });
    return;
  }
  const NeighborLists& ff = neighbors.fluid_fluid;
  const NeighborLists& fb = neighbors.fluid_boundary;
  const std::vector<Vec3>& x = fluid.x;
  const std::vector<Vec3>& xb = bodies.x;
  const std::vector<Vec3>& vb = bodies.v;
  const std::vector<Real>& Vb = bodies.volume;
  const Real mass = constants_.mass;
  const Real h = constants_.support;
  const CubicKernel& kernel = constants_.kernel;
  const GridPoints points = neighbors.fluidPoints(fluid);  // the positions as the search read them
  Vec4Array& dv = scratch.dv;
  std::vector<Real>& volume = scratch.volume;
  Vec4Array& v4 = scratch.v4;
  dv.resize(n);
  const Real nu = Real(visc.coefficient), nub = Real(visc.boundary);
  const bool xsph = visc.model == ViscosityModel::Xsph;
  const Real eps = Real(0.01) * h * h;  // m^2
  // Fluid volumes m_j/rho_j (m^3), once per particle rather than a division per pair.
  volume.resize(n);
  parallelFor(n, [&](std::size_t i) { volume[i] = mass / fluid.rho[i]; });
  if (xsph)
  {
    v4.resize(n);
    parallelFor(n, [&](std::size_t i) { v4[i] << v[i], Real(0); });
  }
  parallelFor(n, [&](std::size_t i) {
    const Vec3 xi = x[i], vi = v[i];
    Vec3 acc = Vec3::Zero();
    if (xsph)
    {
      // Eq. A14; W_ij from the positions (the fluid-fluid lists store no W), W_ib from the lists.
      const Vec4 vi4 = v4[i];
      Vec4 acc4 = Vec4::Zero();
      const Index row_end = ff.offset[i + 1];
      for (Index k0 = ff.offset[i]; k0 < row_end; k0 += kWeightChunk)
      {
        const Index m = std::min(kWeightChunk, row_end - k0);
        Real w[kWeightChunk];  // 1/m^3
        fluidPairWeights(kernel, xi, points, ff.index.data() + k0, m, w);
        for (Index t = 0; t < m; ++t)
        {
          const Index j = ff.index[k0 + t];
          acc4 -= (nu * volume[j] * w[t]) * (vi4 - v4[j]);
        }
      }
      acc = acc4.template head<3>();
      if (nub != 0)
        for (Index k = fb.offset[i]; k < fb.offset[i + 1]; ++k)
        {
          const Index b = fb.index[k];
          acc -= (nub * Vb[b] * fb.weight[k]) * (vi - vb[b]);
        }
    }
    else
    {
      for (Index k = ff.offset[i]; k < ff.offset[i + 1]; ++k)
      {
        const Index j = ff.index[k];
        acc += artificialViscosity(nu, volume[j], xi - x[j], vi - v[j], ff.grad_factor[k], eps);
      }
      if (nub != 0)
        for (Index k = fb.offset[i]; k < fb.offset[i + 1]; ++k)
        {
          const Index b = fb.index[k];
          acc += artificialViscosity(nub, Vb[b], xi - xb[b], vi - vb[b], fb.grad_factor[k], eps);
        }
    }
    dv[i] << (xsph ? acc : Vec3(acc * dtr)), Real(0);  // XSPH is a velocity correction, not an acceleration
  });
  if (nub > 0 && bodies.size() > 0)
  {
    // Reaction on the bodies: the momentum the fluid lost to boundary viscosity, per unit time
    // (serial: a sum per body in a fixed order).
    for (std::size_t i = 0; i < n; ++i)
      for (Index k = fb.offset[i]; k < fb.offset[i + 1]; ++k)
      {
        const Index b = fb.index[k];
        const Vec3 vib = v[i] - vb[b];
        const Vec3 dvb = xsph ? Vec3(-(nub * Vb[b] * fb.weight[k]) * vib)
                              : Vec3(artificialViscosity(nub, Vb[b], x[i] - xb[b], vib, fb.grad_factor[k], eps) * dtr);
        const Vec3d f = -(double(mass) / dt) * dvb.cast<double>();  // N
        const Index body = bodies.body_of[b];
        wrenches.force[body] += f;
        wrenches.torque[body] += (xb[b].cast<double>() - bodies[body].pose.translation).cross(f);
      }
  }
  parallelFor(n, [&](std::size_t i) { v[i] += dv[i].head<3>() + dtr * gravity; });
}

}  // namespace fluid_sim
