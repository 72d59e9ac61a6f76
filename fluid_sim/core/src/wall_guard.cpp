// The wall guard, Eq. A31 of docs/method.md (see wall_guard.h).

#include "fluid_sim/core/wall_guard.h"

#include <algorithm>
#include <cmath>

#include "fluid_sim/core/boundary_sampling.h"
#include "fluid_sim/core/parallel.h"

namespace fluid_sim
{
namespace
{
/// Regula falsi steps of the search along the wall normal for c = limit: c falls monotonically
/// along it over the search's reach, and ten (Illinois) steps put it within 1e-4 of the limit.
constexpr int kSearchSteps = 10;

/// The part of the limit by which c may still exceed it at the search's full reach for the guard
/// to act (the regula falsi's own accuracy, 1e-4, with room for rounding).
constexpr Real kUnreachable = Real(1e-3);

/// Pieces (m, in spacings) a step's motion relative to the walls is checked in for crossing a
/// layer: a particle carried through a layer passes within 0.125 spacings of it at one of the
/// pieces' ends, where c of a flat layer exceeds 0.6, above any guard distance's (0.49 at 0.5).
constexpr double kCrossingPiece = 0.25;
/// How much of that path is checked (spacings): the step's lists hold the boundary particles
/// within 2 spacings of its start, which no point farther than 4 spacings along the path sees.
/// Without the bound a blown-up particle (km per step) cost millions of checks in one step: an
/// unstable run at 8 ms steps, which the stability check stops after the step, hung in it.
constexpr double kCrossingReach = 4.0;

/// c (unit-less) and grad c (1/m) at x over row i's boundary particles, each moved by dt v_b
/// (Eq. A31); also the walls' velocity there, the boundary velocities weighted by V_b W (m/s).
struct Fill
{
  Real c = 0;
  Vec3 grad = Vec3::Zero();
  Vec3 wall_velocity = Vec3::Zero();
};

Fill fillAt(const Vec3& x, std::size_t i, Real dt, const CubicKernel& kernel, const BodySet& bodies,
            const NeighborLists& lists)
{
  Fill f;
  const Real h2 = kernel.support() * kernel.support();
  Real weight = 0;
  for (Index q = lists.offset[i]; q < lists.offset[i + 1]; ++q)
  {
    const Index b = lists.index[q];
    const Vec3 r = x - (bodies.x[b] + dt * bodies.v[b]);
    const Real r2 = r.squaredNorm();
    if (!(r2 < h2)) continue;
    const Real w = bodies.volume[b] * kernel.W(std::sqrt(r2));
    f.c += w;
    f.grad += bodies.volume[b] * kernel.gradW(r);
    f.wall_velocity += w * bodies.v[b];
    weight += w;
  }
  if (weight > 0) f.wall_velocity /= weight;
  return f;
}
}  // namespace

void WallGuard::prepare(double distance, double spacing, const CubicKernel& kernel, const FluidParticles& fluid,
                        const BodySet& bodies, const NeighborLists& fluid_boundary)
{
  particle_.clear();
  if (!(distance > 0)) return;
  const Real c_max = Real(flatLayerFill(spacing, kernel.support(), distance));  // Eq. A31
  spacing_ = spacing;
  const std::size_t n = fluid.size();
  // The rows with boundary neighbours, in particle order (serial: one test per row).
  for (std::size_t i = 0; i < n; ++i)
    if (fluid_boundary.offset[i] != fluid_boundary.offset[i + 1]) particle_.push_back(Index(i));
  const std::size_t m = particle_.size();
  limit_.resize(m);
  start_.resize(m);
  const std::vector<Real>& Vb = bodies.volume;
  parallelFor(m, [&](std::size_t k) {
    const Index i = particle_[k];
    Real c = 0;  // Eq. A31 at x(t), from the search's W
    for (Index q = fluid_boundary.offset[i]; q < fluid_boundary.offset[i + 1]; ++q)
      c += Vb[fluid_boundary.index[q]] * fluid_boundary.weight[q];
    limit_[k] = std::max(c_max, c);
    start_[k] = fluid.x[i];
  });
}

WallGuardReport WallGuard::apply(double dt, const CubicKernel& kernel, FluidParticles& fluid, const BodySet& bodies,
                                 Real mass, BodyWrenches& wrenches, const NeighborLists& fluid_boundary)
{
  WallGuardReport report;
  const std::size_t m = particle_.size();
  if (m == 0) return report;
  const Real step = Real(dt);
  dv_.assign(m, Vec3::Zero());
  shift_.assign(m, Real(0));
  normal_.assign(m, Vec3::Zero());
  const Real piece = Real(kCrossingPiece * spacing_);
  parallelFor(m, [&](std::size_t k) {
    const Index i = particle_[k];
    const Vec3 x_end = fluid.x[i];
    Fill f = fillAt(x_end, i, step, kernel, bodies, fluid_boundary);
    // The step's motion relative to the walls (their velocity weighted as c, at the end).
    const Vec3 motion = (x_end - start_[k]) - step * f.wall_velocity;
    const Real length = motion.norm();
    // Where the guard acts from: the end of the step, or, for a step that ended clear of the
    // walls but passed over a layer on the way, the first point of its path too close.
    Vec3 x = x_end;
    Real tau = 1;  // fraction of the step at x
    if (!(f.c > limit_[k]))
    {
      const double pieces = std::ceil(double(length) / double(piece));
      if (!std::isfinite(pieces)) return;  // a non-finite step: the stability check reports it
      const double checked = std::min(pieces, std::ceil(kCrossingReach / kCrossingPiece));
      bool crossed = false;
      for (int p = 1; p < checked && !crossed; ++p)
      {
        tau = Real(double(p) / pieces);
        x = start_[k] + tau * (x_end - start_[k]);
        f = fillAt(x, i, tau * step, kernel, bodies, fluid_boundary);
        crossed = f.c > limit_[k];
      }
      if (!crossed) return;
    }
    // Along n = -grad c / |grad c| from x, at most the step's own motion relative to the walls
    // (never pushed beyond where it started from them), to where c = limit.
    const Real g_norm = f.grad.norm();
    if (!(g_norm > 0)) return;
    const Vec3 normal = -f.grad / g_norm;  // into the fluid
    const Real reach = tau * length;
    Real lo = 0, hi = reach, c_lo = f.c - limit_[k];
    Real c_hi = fillAt(x + hi * normal, i, tau * step, kernel, bodies, fluid_boundary).c - limit_[k];
    // Where even the whole reach leaves c above the limit (beyond the search's 0.1 % of it), no
    // point the step could have come from is clear of the walls: a gap closing on the particle
    // from both sides, whose badly defined normal a push would follow into the other wall (the
    // squeeze test with the guard at 0.5: a particle thrown at 26 m/s). The pressure solve is
    // left to it.
    if (c_hi > kUnreachable * limit_[k]) return;
    Real t = hi;
    if (c_hi < 0)
    {
      int side = 0;  // Illinois: halve the value of an end kept twice
      for (int it = 0; it < kSearchSteps; ++it)
      {
        t = (lo * c_hi - hi * c_lo) / (c_hi - c_lo);
        const Real c_t = fillAt(x + t * normal, i, tau * step, kernel, bodies, fluid_boundary).c - limit_[k];
        if (c_t > 0)
        {
          lo = t;
          c_lo = c_t;
          if (side == -1) c_hi *= Real(0.5);
          side = -1;
        }
        else
        {
          hi = t;
          c_hi = c_t;
          if (side == 1) c_lo *= Real(0.5);
          side = 1;
        }
      }
      t = hi;  // the end on the allowed side
    }
    x += t * normal;
    // The rest of the step from the guarded point on moves with the walls.
    x += (Real(1) - tau) * step * f.wall_velocity;
    if (x == x_end) return;
    shift_[k] = (x - x_end).norm();
    fluid.x[i] = x;
    const Real vn = normal.dot(fluid.v[i] - f.wall_velocity);  // m/s, < 0 towards the walls
    if (vn < 0)
    {
      dv_[k] = -vn * normal;
      fluid.v[i] += dv_[k];
    }
    normal_[k] = normal;
  });
  // The walls' share of the momentum: serial over the guarded particles (few), in particle order.
  const Real f_scale = mass / step;  // kg/s: m dv / dt is the force on the fluid
  std::vector<Real> push;            // per pair of the row: V_b grad W_ib . n (1/m), towards the fluid
  for (std::size_t k = 0; k < m; ++k)
  {
    if (!(shift_[k] > 0)) continue;
    ++report.particles;
    report.max_shift = std::max(report.max_shift, double(shift_[k]));
    if (dv_[k].squaredNorm() == 0 || bodies.size() == 0) continue;
    const Index i = particle_[k], begin = fluid_boundary.offset[i], end = fluid_boundary.offset[i + 1];
    const Vec3 x = fluid.x[i];
    // Each boundary particle's share of the walls' push along the normal: the shares add up to 1.
    push.assign(end - begin, Real(0));
    Real total = 0;
    for (Index q = begin; q < end; ++q)
    {
      const Index b = fluid_boundary.index[q];
      push[q - begin] = -bodies.volume[b] * kernel.gradW(x - (bodies.x[b] + step * bodies.v[b])).dot(normal_[k]);
      total += push[q - begin];
    }
    if (!(total > 0)) continue;
    const Vec3d force = -(f_scale * dv_[k]).template cast<double>();  // N, on the walls together
    for (Index q = begin; q < end; ++q)
    {
      if (push[q - begin] == 0) continue;
      const Index b = fluid_boundary.index[q];
      const Index body = bodies.body_of[b];
      const Vec3d fb = double(push[q - begin] / total) * force;
      wrenches.force[body] += fb;
      wrenches.torque[body] += (bodies.x[b].template cast<double>() - bodies[body].pose.translation).cross(fb);
    }
  }
  return report;
}

}  // namespace fluid_sim
