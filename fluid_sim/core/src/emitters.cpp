// Emitters (see emitters.h; docs/method.md, Emitters).

#include "fluid_sim/core/emitters.h"

#include <algorithm>
#include <cmath>

#include "fluid_sim/core/bodies.h"
#include "fluid_sim/core/fluid_particles.h"

namespace fluid_sim
{
namespace
{
/// The opening's lattice (nozzle frame, z = 0, m): points one spacing apart, centred on the
/// origin. A circle keeps the points within its radius, a rectangle has round(w/s) x round(h/s)
/// of them; an opening narrower than a spacing still has its centre point.
std::vector<Vec3d> nozzleLattice(const EmitterConfig& e, double s)
{
  std::vector<Vec3d> points;
  if (e.shape == NozzleShape::Circle)
  {
    const int n = int(std::floor(e.radius / s + 1e-9));
    for (int j = -n; j <= n; ++j)
      for (int i = -n; i <= n; ++i)
        if (double(i * i + j * j) * s * s <= e.radius * e.radius * (1 + 1e-9)) points.emplace_back(i * s, j * s, 0.0);
  }
  else
  {
    const int nx = std::max(1, int(std::lround(e.size.x() / s)));
    const int ny = std::max(1, int(std::lround(e.size.y() / s)));
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) points.emplace_back((i - 0.5 * (nx - 1)) * s, (j - 0.5 * (ny - 1)) * s, 0.0);
  }
  if (points.empty()) points.emplace_back(0.0, 0.0, 0.0);
  return points;
}
}  // namespace

Emitters::Emitters(const SceneConfig& scene, const BodySet& bodies)
    : spacing_(scene.spacing), rest_density_(Real(scene.rest_density)), max_fluid_particles_(scene.max_fluid_particles)
{
  const double s = scene.spacing;
  for (std::size_t i = 0; i < scene.emitters.size(); ++i)
  {
    const EmitterConfig& e = scene.emitters[i];
    Nozzle nz;
    nz.config = e;
    nz.points = nozzleLattice(e, s);
    const double n = double(nz.points.size());
    // Flow rate Q = n s^2 v: each layer of n particles stands for n s^3 and one leaves every s / v.
    nz.speed = e.speed > 0.0 ? e.speed : e.flow_rate / (n * s * s);  // m/s
    if (!e.body.empty())
    {
      for (std::size_t b = 0; b < bodies.size(); ++b)
        if (bodies[b].config.name == e.body) nz.body = long(b);
      if (nz.body < 0)
        throw ConfigError("emitters[" + std::to_string(i) + "].body", "no boundary body named '" + e.body + "'");
    }
    if (e.max_particles > 0)
      nz.budget = e.max_particles;
    else if (std::isfinite(e.duration))
    {
      // Whole layers plus the closing part of one; bounded so that a long duration cannot overflow
      // (the scene's max_fluid_particles bounds what is released anyway).
      const double layers = std::ceil(nz.speed * e.duration / s + 1e-9);
      nz.budget = std::size_t(std::min(n * layers, 1.0e15));
    }
    EmitterTotal total;
    total.name = e.name;
    total.speed = nz.speed;
    total.points = nz.points.size();
    total.flow_rate = n * s * s * nz.speed;
    totals_.push_back(total);
    nozzles_.push_back(std::move(nz));
  }
}

std::size_t Emitters::expectedParticles() const
{
  std::size_t n = 0;
  for (const Nozzle& nz : nozzles_) n = std::min(n + std::min(nz.budget, max_fluid_particles_), max_fluid_particles_);
  return n;
}

void Emitters::setPose(std::size_t index, const Pose& pose)
{
  nozzles_.at(index).config.pose = pose;
}

Pose Emitters::worldPose(std::size_t index, const BodySet& bodies) const
{
  const Nozzle& nz = nozzles_.at(index);
  if (nz.body < 0) return nz.config.pose;
  const Pose& body = bodies[std::size_t(nz.body)].pose;
  Pose out;
  out.rotation = body.rotation * nz.config.pose.rotation;
  out.translation = body.apply(nz.config.pose.translation);
  return out;
}

std::size_t Emitters::emit(double t, double dt, FluidParticles& fluid, const BodySet& bodies)
{
  const double s = spacing_;
  std::size_t added = 0;
  for (std::size_t k = 0; k < nozzles_.size(); ++k)
  {
    Nozzle& nz = nozzles_[k];
    EmitterTotal& total = totals_[k];
    if (nz.done || total.budget_reached) continue;
    const double open_at = nz.config.start, close_at = nz.config.start + nz.config.duration;  // s
    if (t + dt <= open_at) continue;
    // Water that has passed the opening while it was open (m of stream at the exit speed), and
    // how far the stream has moved since it opened, also after it closed (m).
    nz.passed += nz.speed * std::max(0.0, std::min(t + dt, close_at) - std::max(t, open_at));
    nz.moved += nz.speed * (t + dt - std::max(t, open_at));
    const double layers = nz.passed / s;  // layers of water due
    const std::size_t whole = std::size_t(std::floor(layers + 1e-9));
    // After closing, the water that passed since the last whole layer (a fraction of one) leaves
    // as part of a layer once it is a spacing clear of that layer: the volume released then
    // matches flow rate x duration to within one particle, not one layer.
    const bool closed = t + dt >= close_at;
    const std::size_t tail_points =
        closed ? std::size_t(std::lround((layers - double(whole)) * double(nz.points.size()))) : 0;
    const bool tail_due = closed && nz.moved >= double(whole + 1) * s;
    if (nz.layers == whole && !tail_due)
    {
      if (closed && tail_points == 0) nz.done = true;
      continue;
    }

    const Pose pose = worldPose(k, bodies);
    const Mat3d R = pose.rotation.toRotationMatrix();
    const Vec3d axis = R.col(2);  // the exit direction, world
    // The body's velocity at a point (m/s); zero for a nozzle in the world.
    const Body* body = nz.body >= 0 ? &bodies[std::size_t(nz.body)] : nullptr;
    const auto carried = [&](const Vec3d& p) -> Vec3d {
      return body ? Vec3d(body->v_origin + body->omega.cross(p - body->pose.translation)) : Vec3d::Zero();
    };
    // Water and walls near the opening: a point closer than half a spacing to either is left
    // out (a release into them would overlap and splash). Candidates are gathered once per step
    // from a sphere that holds every layer released in it.
    double extent = 0.0;  // m, the opening's radius
    for (const Vec3d& q : nz.points) extent = std::max(extent, q.norm());
    const double reach = extent + (nz.moved - double(nz.layers) * s) + 2.0 * s;  // m
    const double clear2 = 0.25 * s * s;                                          // m^2, (s/2)^2
    std::vector<Vec3d> near;
    const auto gather = [&](const std::vector<Vec3>& xs) {
      for (const Vec3& x : xs)
      {
        const Vec3d xd = x.cast<double>();
        if ((xd - pose.translation).squaredNorm() < reach * reach) near.push_back(xd);
      }
    };
    gather(fluid.x);
    gather(bodies.x);

    // Layer k (counted from 1) left when the stream had moved k spacings; it has since moved the
    // rest, nz.moved - k s, along the axis.
    const auto release = [&](std::size_t count, double offset) {
      // A partial layer takes its points spread evenly over the opening (every stride-th).
      const double stride = double(nz.points.size()) / double(count);
      for (std::size_t c = 0; c < count; ++c)
      {
        if ((nz.budget > 0 && total.particles >= nz.budget) || fluid.size() >= max_fluid_particles_)
        {
          total.budget_reached = true;
          return;
        }
        const Vec3d& q = nz.points[std::min(nz.points.size() - 1, std::size_t(double(c) * stride))];
        const Vec3d p = pose.apply(q) + offset * axis;  // m, world
        bool clear = true;
        for (const Vec3d& x : near)
          if ((x - p).squaredNorm() < clear2)
          {
            clear = false;
            break;
          }
        if (!clear)
        {
          ++total.blocked;
          continue;
        }
        const Vec3d v = nz.speed * axis + carried(p);  // m/s
        fluid.add(p.cast<Real>(), v.cast<Real>(), rest_density_);
        near.push_back(p);
        ++total.particles;
        ++added;
      }
    };
    while (nz.layers < whole && !total.budget_reached)
    {
      ++nz.layers;
      release(nz.points.size(), nz.moved - double(nz.layers) * s);
    }
    if (tail_due && !total.budget_reached)
    {
      release(tail_points, nz.moved - double(whole + 1) * s);
      nz.done = true;
    }
    total.volume = double(total.particles) * s * s * s;
    total.mass = total.volume * double(rest_density_);
  }
  return added;
}

}  // namespace fluid_sim
