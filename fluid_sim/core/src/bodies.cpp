// Boundary bodies: sampling and volumes at construction, poses, velocities and accelerations
// each step (Eq. A17 of docs/method.md).

#include "fluid_sim/core/bodies.h"

#include <algorithm>
#include <cmath>

#include "fluid_sim/core/boundary_sampling.h"
#include "fluid_sim/core/parallel.h"
#include "fluid_sim/core/rigid_dynamics.h"

namespace fluid_sim
{
namespace
{
/// A free body lighter than this fraction of the water it displaces is warned about (BodySet).
constexpr double kLightBodyRatio = 0.01;
/// Rotation vector (axis * angle, rad) of a rotation.
Vec3d rotationVector(const Eigen::Quaterniond& q)
{
  Eigen::AngleAxisd aa(q.normalized());
  double angle = aa.angle();
  if (angle > M_PI) angle -= 2.0 * M_PI;
  return aa.axis() * angle;
}

/// Ramp of scripted motion with a start time, a ramp or a stop (Eq. A17): at `time` (s), the
/// factor r of the configured velocities (dimensionless), its rate dr (1/s), and its integral since
/// the start, s = int_start^time r dt' (s), the time the body would have needed at full speed for
/// the same displacement. With tau = time - start, u = tau / ramp, E = stop - start and
/// v = (tau - (E - ramp)) / ramp:
///   tau < 0:                 r = 0, dr = 0, s = 0
///   0 <= tau < ramp:         r = u - sin(2 pi u) / (2 pi),  dr = (1 - cos(2 pi u)) / ramp,
///                            s = ramp (u^2 / 2 - (1 - cos(2 pi u)) / (4 pi^2))
///   ramp <= tau < E - ramp:  r = 1, dr = 0, s = tau - ramp / 2
///   E - ramp <= tau < E:     r = 1 - (v - sin(2 pi v) / (2 pi)),  dr = -(1 - cos(2 pi v)) / ramp,
///                            s = E - 3 ramp / 2 + ramp (v - v^2 / 2 + (1 - cos(2 pi v)) / (4 pi^2))
///   tau >= E:                r = 0, dr = 0, s = E - ramp
/// r is C2 (dr and its rate vanish at the ends of both ramps): velocities and accelerations are
/// continuous. validate() asks for E >= 2 ramp, so the two ramps do not overlap.
struct MotionRamp
{
  double r = 0.0;   // dimensionless
  double dr = 0.0;  // 1/s
  double s = 0.0;   // s
};

/// The rising ramp's r, dr and s at u in (0, 1), for a ramp of `ramp` seconds.
MotionRamp rising(double u, double ramp)
{
  MotionRamp out;
  const double half_sin = std::sin(M_PI * u);
  const double one_minus_cos = 2.0 * half_sin * half_sin;  // 1 - cos(2 pi u), without cancellation
  out.r = u - std::sin(2.0 * M_PI * u) / (2.0 * M_PI);
  out.dr = one_minus_cos / ramp;
  out.s = ramp * (0.5 * u * u - one_minus_cos / (4.0 * M_PI * M_PI));
  return out;
}

MotionRamp motionRamp(const MotionConfig& m, double time)
{
  MotionRamp out;
  const double tau = time - m.start;  // s since the start
  if (!(tau >= 0.0)) return out;
  const double end = m.stop - m.start;  // s, infinite without a stop
  if (tau >= end)                       // still again at the pose reached
  {
    out.s = end - m.ramp;
    return out;
  }
  if (tau >= end - m.ramp)  // slowing down: the rising ramp mirrored (ramp > 0 here)
  {
    const MotionRamp up = rising((tau - (end - m.ramp)) / m.ramp, m.ramp);
    out.r = 1.0 - up.r;
    out.dr = -up.dr;
    out.s = (end - 1.5 * m.ramp) + (tau - (end - m.ramp)) - up.s;
    return out;
  }
  if (tau >= m.ramp)  // without a ramp: full speed from the start (r = 1, s = time - start)
  {
    out.r = 1.0;
    out.s = tau - 0.5 * m.ramp;
    return out;
  }
  return rising(tau / m.ramp, m.ramp);  // ramp > 0 here
}

/// The largest r over [t0, t1] (s): r rises, holds at 1 and falls.
double largestRamp(const MotionConfig& m, double t0, double t1)
{
  const double plateau_begin = m.start + m.ramp, plateau_end = m.stop - m.ramp;  // s
  if (t0 <= plateau_end && t1 >= plateau_begin) return 1.0;
  return std::max(motionRamp(m, t0).r, motionRamp(m, t1).r);
}
}  // namespace

BodySet::BodySet(const SceneConfig& scene)
{
  std::size_t offset = 0;
  for (const BoundaryConfig& cfg : scene.boundaries)
  {
    Body body;
    body.config = cfg;
    if (body.config.type == ShapeType::Cylinder) body.config.cylinder.axis.normalize();
    const double sample_spacing = sampleSpacing(cfg, scene.spacing);  // m
    body.local = sampleBoundary(body.config, sample_spacing, scene.spacing);
    for (const Vec3d& p : body.local) body.reach = std::max(body.reach, p.norm());
    body.offset = offset;
    body.initial_pose = cfg.pose;
    body.pose = cfg.pose;
    body.moving = cfg.externally_posed || !cfg.motion.isStatic() || cfg.dynamic.enabled;
    if (cfg.dynamic.enabled)
    {
      // Mass properties of the shape as given, before sampling (rigid_dynamics.cpp).
      const std::string key = dynamicKey(cfg, bodies_.size());
      const MassProperties mp = massProperties(body.config, key);
      // A centre of mass beyond every particle of the body (by more than a spacing) is not the
      // body's: most likely a unit or frame mistake (it sent a box 5 m away falling through the
      // floor).
      if (cfg.dynamic.center_of_mass && mp.com.norm() > body.reach + scene.spacing)
        throw ConfigError(key + ".center_of_mass",
                          "lies " + numberText(mp.com.norm()) + " m from the body frame's origin, outside '" +
                              cfg.name + "', whose particles reach at most " + numberText(body.reach) + " m from it");
      // The coupling is explicit and carries no added mass: submerged, a body of mean density
      // rho_b accelerates at up to (rho0 / rho_b - 1) g where a real one is held to about 2 g by
      // the water it must push aside. Stable and plausible down to 10 kg/m^3 for water (a
      // 16 x 16 x 6 cm box dropped half-submerged in a tank, 2 cm spacing); at 1 kg/m^3 it was
      // thrown 0.23 m clear in 0.1 s, at 1e-4 kg/m^3 it blew up: most likely grams or litres.
      if (!(body.config.type == ShapeType::Mesh && !body.config.mesh_closed))
      {
        const double volume = shapeMass(body.config, key).volume;  // m^3
        const double ratio = mp.mass / (scene.rest_density * volume);
        if (ratio < kLightBodyRatio)
          start_warnings_.push_back("free body '" + cfg.name + "' is " + numberText(mp.mass) + " kg for " +
                                    numberText(volume) + " m^3, a mean density of " + numberText(mp.mass / volume) +
                                    " kg/m^3: below " + numberText(kLightBodyRatio) + " of the water's " +
                                    numberText(scene.rest_density) +
                                    " kg/m^3 the coupling (no added mass) throws it clear or blows up; check " + key +
                                    " (units: kg, kg/m^3)");
      }
      body.free = true;
      body.mass = mp.mass;
      body.com_local = mp.com;
      body.inertia_local = mp.inertia;
      body.v_com = cfg.dynamic.linear_velocity;
      body.omega = cfg.dynamic.angular_velocity;
      has_free_ = true;
    }
    offset += body.local.size();
    bodies_.push_back(std::move(body));
  }
  x.resize(offset);
  v.assign(offset, Vec3::Zero());
  a.assign(offset, Vec3::Zero());
  volume.resize(offset);
  body_of.resize(offset);
  // Eq. A3: V_b = gamma / sum_b' W_bb' over the body's own particles, gamma the flat-layer factor.
  const double gamma = flatLayerVolumeFactor(scene.spacing, 2.0 * scene.spacing);
  for (std::size_t bi = 0; bi < bodies_.size(); ++bi)
  {
    Body& body = bodies_[bi];
    const std::vector<Real> vol = boundaryVolumes(body.local, 2.0 * scene.spacing, gamma);
    for (std::size_t k = 0; k < body.local.size(); ++k)
    {
      volume[body.offset + k] = vol[k];
      body_of[body.offset + k] = Index(bi);
    }
    pose(body, 0.0, true);
  }
  if (has_free_) checkFreeStart();
}

void BodySet::checkFreeStart()
{
  // A particle of the free body inside another body's solid, or on the far side of a container's
  // wall, means the two overlap by at least the half spacing the particle layer lies inside its
  // surface: bodies that merely touch (a box on the floor, two boxes side by side) pass.
  bool containers = false;
  for (const Body& other : bodies_) containers = containers || (other.config.inside && !other.openShell());
  for (const Body& body : bodies_)
  {
    if (!body.free) continue;
    const std::size_t n = body.local.size();
    bool in_some_container = false;
    for (const Body& other : bodies_)
    {
      if (&other == &body || other.openShell()) continue;
      std::size_t inside = 0;
      for (std::size_t k = body.offset; k < body.offset + n; ++k)
      {
        const Vec3d local = other.pose.rotation.conjugate() * (x[k].cast<double>() - other.pose.translation);
        inside += insideShape(other.config, local) ? 1 : 0;
      }
      if (other.config.inside)
      {
        in_some_container = in_some_container || inside > 0;
        if (inside > 0 && inside < n)
          start_warnings_.push_back("free body '" + body.config.name + "' starts across the wall of '" +
                                    other.config.name + "' (" + std::to_string(n - inside) + " of its " +
                                    std::to_string(n) + " particles outside it): it will be thrown clear at once; " +
                                    "start it inside, clear of the wall");
      }
      else if (inside > 0)
        start_warnings_.push_back("free body '" + body.config.name + "' starts overlapping '" + other.config.name +
                                  "' (" + std::to_string(inside) + " of its " + std::to_string(n) +
                                  " particles inside it): it will be thrown clear at once; start it clear");
    }
    if (containers && !in_some_container)
      start_warnings_.push_back("free body '" + body.config.name +
                                "' starts outside every container: nothing holds it, and it will fall out of the "
                                "domain");
  }
}

void BodySet::poseMoving(double time)
{
  for (Body& body : bodies_)
    if (body.moving && !body.free) pose(body, time, false);  // free bodies are written by stepFree()
}

double BodySet::maxSpeedAhead(double time, double horizon) const
{
  double speed = 0.0;  // m/s
  for (const Body& body : bodies_)
  {
    // Scripted bodies only. A free body's velocity comes out of its contacts, a posed one's from
    // differences of its poses. Counted, the demo's floating box (added to bench_robot's scene)
    // knocked by the paddle read 3-9 m/s for single steps (the water 0.35 m/s), its step fell to
    // 0.9 ms and the contacts over the shorter step gave larger velocities again; the tf-driven
    // demo went unstable in 2 of 10 runs of 25-40 s with them counted (none in 6 since).
    if (!body.moving || body.free || body.config.externally_posed) continue;
    // Scripted (Eq. A17): a particle's velocity is r (u + w x (x - about - u s)), and x - about - u s
    // is its initial offset from the axis point, rotated about the axis: its distance from the
    // axis stays that of the origin's initial offset plus reach at most.
    const MotionConfig& m = body.config.motion;
    const double r = largestRamp(m, time, time + horizon);  // the ramp's factor over the horizon
    const double w = m.angular_velocity.norm();             // rad/s
    Vec3d arm = body.initial_pose.translation - m.about;    // m
    if (w > 0.0) arm -= arm.dot(m.angular_velocity / w) * (m.angular_velocity / w);
    speed = std::max(speed, r * (m.linear_velocity.norm() + w * (arm.norm() + body.reach)));
  }
  return speed;
}

void BodySet::setPendingPose(std::size_t index, const Pose& pose, bool jump)
{
  Body& body = bodies_.at(index);
  body.pending_pose = pose;
  body.pose_pending = true;
  body.pose_jump = jump;
}

/// Eq. A17, scripted: rotation about `about` at constant angular velocity, then translation, after
/// `time` seconds at full speed (with a start or a ramp, `time` is the ramp's integral s).
Pose BodySet::scriptedPose(const Body& body, double time) const
{
  const MotionConfig& m = body.config.motion;
  const double w = m.angular_velocity.norm();  // rad/s
  Eigen::Quaterniond rot = Eigen::Quaterniond::Identity();
  if (w > 0.0) rot = Eigen::Quaterniond(Eigen::AngleAxisd(w * time, m.angular_velocity / w));
  Pose out;
  out.rotation = (rot * body.initial_pose.rotation).normalized();
  out.translation = m.about + rot * (body.initial_pose.translation - m.about) + m.linear_velocity * time;
  return out;
}

/// Moves `body` to its pose at `time` and, if it moved (or force_write), writes its particles'
/// world positions, velocities and accelerations.
void BodySet::pose(Body& body, double time, bool force_write)
{
  if (body.config.externally_posed)
  {
    // Eq. A17, external. A step without a new pose holds the body where it is: its velocities
    // are derived every step, so a body the caller stops has zero velocity at once (not the
    // velocity of its last change of pose).
    const bool at_rest =
        body.v_origin.isZero(0) && body.omega.isZero(0) && body.a_origin.isZero(0) && body.alpha.isZero(0);
    if (!body.pose_pending && body.has_previous_pose && !at_rest)
    {
      body.pending_pose = body.pose;
      body.pose_pending = true;
      body.pose_jump = false;
    }
    if (body.pose_pending)
    {
      const double dt = time - body.last_pose_time;  // s since the previous pose
      if (body.pose_jump)
      {
        body.v_origin.setZero();
        body.omega.setZero();
        body.a_origin.setZero();
        body.alpha.setZero();
      }
      else if (body.has_previous_pose && dt > 0.0)
      {
        // Velocities follow the poses by backward differences over the last interval,
        // accelerations by differences of those.
        const Vec3d v_new = (body.pending_pose.translation - body.pose.translation) / dt;
        const Vec3d w_new = rotationVector(body.pending_pose.rotation * body.pose.rotation.conjugate()) / dt;
        body.a_origin = (v_new - body.v_origin) / dt;
        body.alpha = (w_new - body.omega) / dt;
        body.v_origin = v_new;
        body.omega = w_new;
      }
      const bool unchanged = at_rest && body.v_origin.isZero(0) && body.omega.isZero(0) && body.a_origin.isZero(0) &&
                             body.alpha.isZero(0) && body.pending_pose.translation == body.pose.translation &&
                             body.pending_pose.rotation.coeffs() == body.pose.rotation.coeffs();
      body.pose = body.pending_pose;
      body.last_pose_time = time;
      body.has_previous_pose = true;
      body.pose_pending = false;
      if (!unchanged) force_write = true;  // a body at rest given its own pose again: nothing to rewrite
    }
  }
  else if (body.free)
  {
    // The pose was integrated by stepFree(); the origin's velocity and acceleration follow from
    // the centre of mass's (v_o = v_c + omega x (o - c), a likewise with alpha and the
    // centripetal term).
    const Vec3d arm = body.pose.translation - body.centerOfMass();  // m
    body.v_origin = body.v_com + body.omega.cross(arm);
    force_write = true;
  }
  else if (!body.config.motion.isStatic())
  {
    // Eq. A17, scripted: velocities r times the configured ones (r = 1 without a start or a
    // ramp), the pose their exact integral (the motion at full speed over the time s).
    const MotionConfig& m = body.config.motion;
    const MotionRamp ramp = motionRamp(m, time);
    body.pose = time >= m.start ? scriptedPose(body, ramp.s) : body.initial_pose;  // still before the start
    // Arm from the axis point to the origin, rotated: o - about without the translation u s.
    const Vec3d arm = body.pose.translation - m.about - m.linear_velocity * ramp.s;  // m
    const Vec3d w = m.angular_velocity * ramp.r;                                     // rad/s
    body.omega = w;
    body.v_origin = w.cross(arm) + m.linear_velocity * ramp.r;
    body.alpha = m.angular_velocity * ramp.dr;
    body.a_origin = body.alpha.cross(arm) + w.cross(w.cross(arm)) + m.linear_velocity * ramp.dr;
    force_write = true;
  }
  if (!force_write) return;
  const Mat3d R = body.pose.rotation.toRotationMatrix();
  const Vec3d o = body.pose.translation;
  parallelFor(body.local.size(), [&](std::size_t k) {
    const Vec3d r = R * body.local[k];  // m, from the body origin, world axes
    const std::size_t b = body.offset + k;
    x[b] = (o + r).cast<Real>();
    v[b] = (body.v_origin + body.omega.cross(r)).cast<Real>();
    a[b] = (body.a_origin + body.alpha.cross(r) + body.omega.cross(body.omega.cross(r))).cast<Real>();
  });
  ++(body.moving ? moving_version_ : static_version_);
}

}  // namespace fluid_sim
