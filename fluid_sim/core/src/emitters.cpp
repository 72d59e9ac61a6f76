// Emitters (see emitters.h; docs/method.md, Emitters).

#include "fluid_sim/core/emitters.h"

#include <algorithm>
#include <cmath>

#include "fluid_sim/core/bodies.h"
#include "fluid_sim/core/boundary_sampling.h"
#include "fluid_sim/core/fluid_fill.h"
#include "fluid_sim/core/fluid_particles.h"
#include "fluid_sim/core/kernel.h"

namespace fluid_sim
{
namespace
{
/// How far above rest density (relative) the water and walls around a nozzle point may put a
/// particle released there (the initial fill's tolerance, fill.relax_tolerance's default).
constexpr double kRoomTolerance = 0.02;

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
    : spacing_(scene.spacing)
    , rest_density_(Real(scene.rest_density))
    , max_fluid_particles_(scene.max_fluid_particles)
    , domain_(scene.domain)
{
  const double s = scene.spacing;
  // The shortest step the scene allows (s): the fixed one, or the adaptive step's lower bound.
  const double dt_floor = scene.time_step.adaptive ? scene.time_step.min : scene.time_step.fixed;
  for (std::size_t i = 0; i < scene.emitters.size(); ++i)
  {
    const EmitterConfig& e = scene.emitters[i];
    const std::string key = "emitters[" + std::to_string(i) + "]";
    Nozzle nz;
    nz.config = e;
    nz.points = nozzleLattice(e, s);
    const double n = double(nz.points.size());
    // Flow rate Q = n s^2 v: each layer of n particles stands for n s^3 and one leaves every s / v.
    nz.speed = e.speed > 0.0 ? e.speed : e.flow_rate / (n * s * s);  // m/s
    // A stream that moves more than stability.max_cfl spacings in the shortest step the scene
    // allows trips the stability check with its first layer (and a mistyped exponent in the flow
    // rate would ask for millions of layers in one step): refused before the run starts.
    const double fastest = scene.stability.max_cfl * s / dt_floor;  // m/s
    if (!(nz.speed <= fastest))
    {
      const bool given_rate = !(e.speed > 0.0);
      throw ConfigError(key + (given_rate ? ".flow_rate" : ".speed"),
                        (given_rate ? "flow rate " + numberText(e.flow_rate) + " m^3/s through " +
                                          std::to_string(nz.points.size()) + " nozzle point(s) gives an exit speed of "
                                    : std::string("exit speed ")) +
                            numberText(nz.speed) + " m/s, faster than the " + numberText(fastest) +
                            " m/s that stability.max_cfl (" + numberText(scene.stability.max_cfl) +
                            ") allows at the scene's shortest time step (" + numberText(dt_floor) +
                            " s) and spacing: lower it, or the time step");
    }
    // A nozzle fixed in the world opens inside the domain (as a fluid block must lie in it); one
    // carried by a body or a tf frame may leave it, and its points outside are then left out.
    if (e.body.empty() && e.frame.empty())
    {
      const Vec3d& c = e.pose.translation;
      if (!scene.domain.contains(c))
        throw ConfigError(key + ".pose.xyz", "the nozzle at (" + numberText(c.x()) + ", " + numberText(c.y()) + ", " +
                                                 numberText(c.z()) + ") lies outside the domain");
    }
    if (!e.body.empty())
    {
      for (std::size_t b = 0; b < bodies.size(); ++b)
        if (bodies[b].config.name == e.body) nz.body = long(b);
      if (nz.body < 0) throw ConfigError(key + ".body", "no boundary body named '" + e.body + "'");
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
    // Water, walls and solids near the opening. A point is left out where a particle released
    // there would overlap what is already there and be shot off (a splash, or with MLS a blow-up
    // at a wall): where the water and walls in its kernel's reach would put it more than
    // kRoomTolerance above rest density (Eq. A1 with the wall term of Eq. A3's volumes: in water
    // at rest only a vacancy has room, as "room" means for the fill); closer than half a spacing
    // to water; as close to a wall's particle layer as the initial fill may not come
    // (trimDistance(): the layer lies half a spacing inside the wall, the first water half a
    // spacing in front of it), or 0.75 spacings to an open shell's layer (on its surface); inside a
    // solid; outside the domain. Candidates are gathered once per step from a sphere that holds
    // every layer released in it and its kernel's reach.
    double extent = 0.0;  // m, the opening's radius
    for (const Vec3d& q : nz.points) extent = std::max(extent, q.norm());
    const double reach = extent + (nz.moved - double(nz.layers) * s) + 3.0 * s;  // m
    const double water2 = 0.25 * s * s;                                          // m^2, (s/2)^2
    const double wall2 = trimDistance(s) * trimDistance(s);                      // m^2
    const double shell2 = 0.75 * 0.75 * s * s;                                   // m^2
    const double mass = double(rest_density_) * s * s * s;                       // kg, of one particle
    struct Near
    {
      Vec3d x;      // m, world
      double mass;  // kg: a fluid particle's, or a wall particle's rho0 V_b
    };
    std::vector<Near> water, walls, shells;
    const auto gather = [&](const Vec3& x, double m, std::vector<Near>& into) {
      const Vec3d xd = x.cast<double>();
      if ((xd - pose.translation).squaredNorm() < reach * reach) into.push_back({xd, m});
    };
    for (const Vec3& x : fluid.x) gather(x, mass, water);
    std::vector<const Body*> solids;  // solid bodies that may hold part of the opening's stream
    for (const Body& b : bodies.bodies())
    {
      for (std::size_t k = b.offset; k < b.offset + b.local.size(); ++k)
        gather(bodies.x[k], double(rest_density_) * double(bodies.volume[k]), b.openShell() ? shells : walls);
      if (!b.config.inside && !b.openShell() && (b.pose.translation - pose.translation).norm() < b.reach + reach)
        solids.push_back(&b);
    }
    const CubicKernel kernel(Real(2.0 * s));
    double density = 0.0;  // kg/m^3 at the point last tested
    const auto crowded = [&](const std::vector<Near>& xs, const Vec3d& p, double r2) {
      bool close = false;
      for (const Near& n : xs)
      {
        const double d2 = (n.x - p).squaredNorm();
        close = close || d2 < r2;
        density += n.mass * double(kernel.W(Real(std::sqrt(d2))));
      }
      return close;
    };
    const auto blocked = [&](const Vec3d& p) {
      if (!domain_.contains(p)) return true;
      density = mass * double(kernel.W0());
      const bool close = crowded(water, p, water2) | crowded(walls, p, wall2) | crowded(shells, p, shell2);
      if (close || density > (1.0 + kRoomTolerance) * double(rest_density_)) return true;
      for (const Body* b : solids)
        if (insideShape(b->config, b->pose.rotation.conjugate() * (p - b->pose.translation))) return true;
      return false;
    };

    // Layer k (counted from 1) left when the stream had moved k spacings; it has since moved the
    // rest, nz.moved - k s, along the axis. Its particles stand for the slab of water that passed
    // the opening in its time, one spacing thick: they sit at the slab's middle, half a spacing
    // ahead of where its back has got to (as a fluid block's first lattice layer sits half a
    // spacing from the wall it touches), so a nozzle set on a wall releases where the fill would.
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
        const Vec3d p = pose.apply(q) + (offset + 0.5 * s) * axis;  // m, world
        if (blocked(p))
        {
          ++total.blocked;
          continue;
        }
        const Vec3d v = nz.speed * axis + carried(p);  // m/s
        fluid.add(p.cast<Real>(), v.cast<Real>(), rest_density_);
        water.push_back({p, mass});
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
