#pragma once
// The boundary bodies: their shapes sampled once into particles in the body frame, their poses
// (scripted motion, or poses handed in by the caller), velocities and accelerations (Eq. A17 of
// docs/method.md), the boundary particles' world positions, velocities, accelerations and volumes
// (Eq. A3), and the fluid's force and torque on each body (Eq. A12).

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include "fluid_sim/core/scene_config.h"
#include "fluid_sim/core/types.h"

namespace fluid_sim
{
class ContactResolver;  // rigid_dynamics.h

/// One rigid body and its motion.
struct Body
{
  BoundaryConfig config;
  std::vector<Vec3d> local;        // m, boundary particles in the body frame
  double reach = 0.0;              // m, the largest |local|: how far a particle is from the origin
  std::size_t offset = 0;          // index of its first particle in BoundaryParticles
  Pose pose;                       // body -> world at the current time
  Pose initial_pose;               // at t = 0
  Vec3d v_origin = Vec3d::Zero();  // m/s, velocity of the body origin (world)
  Vec3d omega = Vec3d::Zero();     // rad/s, angular velocity (world)
  Vec3d a_origin = Vec3d::Zero();  // m/s^2, acceleration of the body origin (world)
  Vec3d alpha = Vec3d::Zero();     // rad/s^2, angular acceleration (world)
  bool moving = false;             // scripted motion or externally posed: re-posed every step

  // Externally posed bodies: the pose handed in for the next step.
  bool pose_pending = false;
  bool pose_jump = false;  // the pending pose is a placement, not a motion (no velocity from it)
  bool has_previous_pose = false;
  Pose pending_pose;
  double last_pose_time = 0.0;  // s, simulated time of the current pose

  // What the fluid did to the body in the last step.
  Vec3d force = Vec3d::Zero();   // N, world frame
  Vec3d torque = Vec3d::Zero();  // N m, world frame, about the body origin
  std::size_t contact = 0;       // boundary particles with a fluid neighbour
  double max_pressure = 0.0;     // Pa, largest boundary pressure used (density solve)

  // Free bodies (config.dynamic.enabled, rigid_dynamics.h): mass properties and the velocity of
  // the centre of mass; omega above is the angular velocity.
  bool free = false;
  double mass = 0.0;                    // kg
  Vec3d com_local = Vec3d::Zero();      // m, body frame
  Mat3d inertia_local = Mat3d::Zero();  // kg m^2, about the centre of mass, body axes
  Vec3d v_com = Vec3d::Zero();          // m/s, world
  Vec3d contact_force = Vec3d::Zero();  // N, world: contact impulses of the last step over dt

  Vec3d centerOfMass() const
  {
    return pose.apply(com_local);
  }
  /// An open mesh (a cup, a paddle): a shell with no inside, its particle layer on the surface.
  bool openShell() const
  {
    return config.type == ShapeType::Mesh && !config.mesh_closed;
  }
  /// Inverse inertia in world axes, 1/(kg m^2).
  Mat3d inverseInertiaWorld() const
  {
    const Mat3d R = pose.rotation.toRotationMatrix();
    return R * inertia_local.inverse() * R.transpose();
  }
};

/// Per-body sums of the fluid's force (N) and torque about the body origin (N m), world frame.
struct BodyWrenches
{
  std::vector<Vec3d> force;
  std::vector<Vec3d> torque;

  explicit BodyWrenches(std::size_t bodies = 0) : force(bodies, Vec3d::Zero()), torque(bodies, Vec3d::Zero()) {}
  void add(const BodyWrenches& other)
  {
    for (std::size_t k = 0; k < force.size(); ++k)
    {
      force[k] += other.force[k];
      torque[k] += other.torque[k];
    }
  }
};

/// All bodies and their boundary particles (structure of arrays, bodies one after another).
class BodySet
{
public:
  /// Samples every boundary of the scene (boundary_sampling.h), computes the particle volumes
  /// (Eq. A3) and poses each body at t = 0.
  explicit BodySet(const SceneConfig& scene);

  std::size_t size() const
  {
    return bodies_.size();
  }
  Body& operator[](std::size_t k)
  {
    return bodies_[k];
  }
  const Body& operator[](std::size_t k) const
  {
    return bodies_[k];
  }
  const std::vector<Body>& bodies() const
  {
    return bodies_;
  }
  std::size_t numParticles() const
  {
    return x.size();
  }

  /// Moves every moving body to its pose at `time` (s) and rewrites its particles (Eq. A17).
  void poseMoving(double time);

  /// A bound on the speed (m/s) of any scripted body's particle from `time` to `time + horizon`
  /// (s), for the time step (Eq. A15), from its motion at the largest ramp factor in that window
  /// (the ramp only rises, and a body still before its start counts from the window that reaches
  /// it). Free and posed bodies are not counted (bodies.cpp says why). 0 without scripted motion.
  double maxSpeedAhead(double time, double horizon) const;

  /// Free bodies: one step of dt (s) under gravity (m/s^2), the fluid's force and torque of the
  /// step just solved (Body::force, torque) and contacts (Eqs. A24-A27, rigid_dynamics.cpp,
  /// bullet_contacts.cpp), and their particles written at the new poses (poseMoving() leaves free
  /// bodies alone). Returns "" or, when a free body's velocities came out non-finite, what went
  /// wrong (the body's name, and whether the fluid's wrench or the contacts brought it), for the
  /// step's report: such a body is left as it is and the caller reports the step unstable.
  std::string stepFree(double dt, const Vec3d& gravity, ContactResolver& contacts);
  bool hasFree() const
  {
    return has_free_;
  }
  /// What the build found wrong with the free bodies' start (one line each, naming the bodies):
  /// a free body that starts overlapping another body's solid, across a container's wall, or
  /// outside every container of a scene that has some. Legal, but it will be thrown out of the
  /// overlap at once (or fall out of the domain): most likely a placement mistake.
  const std::vector<std::string>& startWarnings() const
  {
    return start_warnings_;
  }

  /// Stores the caller's pose of an externally posed body for the next poseMoving().
  void setPendingPose(std::size_t index, const Pose& pose, bool jump);

  /// Counts, per body, the boundary particles with a fluid neighbour in `fluid_boundary` (rows:
  /// fluid particles, entries: boundary particles) and the largest boundary pressure among them,
  /// `pressure_at(i, b)` (Pa), and stores `wrenches` as the bodies' forces of this step.
  template <class Lists, class PressureAt>
  void updateReports(const BodyWrenches& wrenches, const Lists& fluid_boundary, std::size_t fluid_count,
                     PressureAt&& pressure_at);

  /// Incremented whenever a particle position changes, of any body, of a body that never moves
  /// (Body::moving false: written when the set is built), and of a moving one (the neighbour
  /// search sorts the static and the moving bodies' particles separately, each when it changed).
  std::uint64_t positionsVersion() const
  {
    return static_version_ + moving_version_;
  }
  std::uint64_t staticVersion() const
  {
    return static_version_;
  }
  std::uint64_t movingVersion() const
  {
    return moving_version_;
  }

  // Boundary particles, world frame.
  std::vector<Vec3> x;         // m, position
  std::vector<Vec3> v;         // m/s, velocity
  std::vector<Vec3> a;         // m/s^2, acceleration (SPH extrapolation's hydrostatic term, Eq. 3)
  std::vector<Real> volume;    // m^3, V_b (Eq. A3)
  std::vector<Index> body_of;  // index of the particle's body

private:
  void pose(Body& body, double time, bool force_write);
  void checkFreeStart();  // fills start_warnings_ (after every body is posed at t = 0)
  Pose scriptedPose(const Body& body, double time) const;

  std::vector<Body> bodies_;
  std::vector<std::uint8_t> contact_mark_;  // per boundary particle, scratch of updateReports
  std::uint64_t static_version_ = 0, moving_version_ = 0;
  bool has_free_ = false;
  std::vector<std::string> start_warnings_;
};

template <class Lists, class PressureAt>
void BodySet::updateReports(const BodyWrenches& wrenches, const Lists& fluid_boundary, std::size_t fluid_count,
                            PressureAt&& pressure_at)
{
  for (std::size_t k = 0; k < bodies_.size(); ++k)
  {
    bodies_[k].force = wrenches.force[k];
    bodies_[k].torque = wrenches.torque[k];
    bodies_[k].contact = 0;
    bodies_[k].max_pressure = 0.0;
  }
  if (bodies_.empty()) return;
  // Serial: cheap, one pass over the fluid-boundary pairs.
  contact_mark_.assign(x.size(), 0);
  for (std::size_t i = 0; i < fluid_count; ++i)
    for (Index k = fluid_boundary.offset[i]; k < fluid_boundary.offset[i + 1]; ++k)
    {
      const Index b = fluid_boundary.index[k];
      Body& body = bodies_[body_of[b]];
      body.max_pressure = std::max(body.max_pressure, double(pressure_at(i, b)));
      if (!contact_mark_[b])
      {
        contact_mark_[b] = 1;
        ++body.contact;
      }
    }
}

}  // namespace fluid_sim
