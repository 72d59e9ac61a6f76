#pragma once
// The converter between the simulation's types and ROS types: particle and boundary clouds,
// wrenches, poses from tf, solver statistics, and the dynamic_reconfigure settings. Every
// conversion the node makes is here; only this layer includes ROS headers.

#include <string>
#include <utility>
#include <vector>

#include <geometry_msgs/Transform.h>
#include <geometry_msgs/TransformStamped.h>
#include <geometry_msgs/Wrench.h>
#include <sensor_msgs/PointCloud2.h>
#include <visualization_msgs/Marker.h>

#include "fluid_msgs/ContactWrench.h"
#include "fluid_msgs/EmitterArray.h"
#include "fluid_msgs/FreeBody.h"
#include "fluid_msgs/Probe.h"
#include "fluid_msgs/RegionState.h"
#include "fluid_msgs/SinkArray.h"
#include "fluid_msgs/SolverStats.h"
#include "fluid_sim/FluidSimConfig.h"
#include "fluid_sim/core/measurements.h"
#include "fluid_sim/core/scene_config.h"
#include "fluid_sim/core/simulation.h"
#include "fluid_sim/core/surface.h"
#include "fluid_sim/core/types.h"

namespace fluid_sim
{
namespace ros_bridge
{
/// Per-particle fluid state copied out of the solver between steps (the solver's arrays are
/// reordered every step, so the publisher works on this copy, never on the live arrays).
struct FluidSnapshot
{
  std::vector<Vec3> positions;   // m, fixed frame
  std::vector<Vec3> velocities;  // m/s
  std::vector<Real> pressures;   // Pa
  std::vector<Real> densities;   // kg/m^3
};

/// Fields of the `particles` cloud, all float32, in this order: x y z (m), vx vy vz (m/s),
/// pressure (Pa), density (kg/m^3), speed (m/s). 36 bytes per point, dense, little-endian.
constexpr int kParticleFields = 9;

/// Fills `cloud` (an unorganised cloud: height 1) from the snapshot, keeping at most
/// `max_points` points (0 = all) by taking every k-th particle, so the decimated cloud still
/// covers the whole fluid. Header is left to the caller.
void fillParticleCloud(const FluidSnapshot& fluid, std::size_t max_points, sensor_msgs::PointCloud2& cloud);

/// Fills `cloud` with boundary particles: float32 x y z (m), pressure (Pa; 0 when the method
/// keeps no boundary pressure, i.e. mirroring) and body (the body's index, in the order of
/// contact_wrenches; a float so that rviz can colour by it). `pressures` may be empty;
/// `body_ranges[k]` = (first particle, count) of body k.
void fillBoundaryCloud(const std::vector<Vec3>& positions, const std::vector<Real>& pressures,
                       const std::vector<std::pair<std::size_t, std::size_t>>& body_ranges,
                       sensor_msgs::PointCloud2& cloud);

/// Fills `marker` (header left to the caller) with the free surface `mesh`: a TRIANGLE_LIST,
/// namespace "surface", id 0, three points (m, the mesh's frame) per triangle in the mesh's
/// counter-clockwise order (rviz lights each triangle by the normal that order gives, outward),
/// identity pose, unit scale, water blue. An empty mesh gives action DELETE (rviz then removes
/// the last surface) and no points.
void fillSurfaceMarker(const SurfaceMesh& mesh, visualization_msgs::Marker& marker);

/// Force (N) and torque (N m) as a message, axes as given.
geometry_msgs::Wrench toWrench(const Vec3d& force, const Vec3d& torque);

/// The ContactWrench of `body` with the given force (N) and torque (N m), both in the body
/// frame, and the largest boundary pressure max_pressure (Pa); name and contact particles from
/// `body`.
fluid_msgs::ContactWrench toContactWrench(const BodyInfo& body, const Vec3d& force, const Vec3d& torque,
                                          double max_pressure);

/// A free body's state (BodyInfo::free) as a message, every vector in the world (fixed) frame:
/// the body frame's pose, the centre of mass and its velocity, the angular velocity, the fluid's
/// force and torque about the centre of mass, the contact force, the mass.
fluid_msgs::FreeBody toFreeBody(const BodyInfo& body);

/// A region's measurement (scene key regions) as a message; the header is the caller's.
fluid_msgs::RegionState toRegionState(const RegionMeasurement& region);

/// A probe's measurement (scene key probes) as a message.
fluid_msgs::Probe toProbe(const ProbeMeasurement& probe);

/// What each emitter released (Simulation::emitterTotals()), stamped and in `frame`.
fluid_msgs::EmitterArray toEmitterArray(const std::vector<EmitterTotal>& emitters, const ros::Time& stamp,
                                        const std::string& frame);

/// What each sink drained (Simulation::sinkTotals()), stamped and in `frame`.
fluid_msgs::SinkArray toSinkArray(const std::vector<SinkTotal>& sinks, const ros::Time& stamp,
                                  const std::string& frame);

/// A tf transform (translation in m) as a pose, its quaternion normalised.
Pose toPose(const geometry_msgs::Transform& transform);

/// `pose` (child -> parent, m) as the tf transform from `parent` to `child` at `stamp`.
geometry_msgs::TransformStamped toTransformStamped(const Pose& pose, const std::string& parent,
                                                   const std::string& child, const ros::Time& stamp);

/// The stats message of step `report` of `sim` (header left to the caller). `real_time_factor`:
/// the measured one (simulated s per wall s); `status`: "ok", "not_converged" or "unstable: ...".
fluid_msgs::SolverStats toSolverStats(const StepReport& report, const Simulation& sim, double real_time_factor,
                                      bool paused, const std::string& status);

/// The dynamic_reconfigure solver and viscosity settings with the values of `solver` and
/// `viscosity`; the node group (publish_rate, real_time_factor, max_points, surface_rate) is left to
/// the caller.
/// The node group starts at the .cfg defaults; call fillReconfigureGroups() after changing it.
fluid_sim::FluidSimConfig toReconfigure(const SolverConfig& solver, const ViscosityConfig& viscosity);

/// Copies every parameter of `c` into its group's copy (c.groups.solver.warm_start, ...), which the
/// generated class's constructors leave uninitialised: copying such a config loaded an
/// indeterminate bool (UBSan: "load of value 64, which is not a valid value for type 'bool'").
void fillReconfigureGroups(fluid_sim::FluidSimConfig& c);

/// Writes the solver and viscosity settings of `config` into `solver` and `viscosity`; their
/// other fields are kept.
void fromReconfigure(const fluid_sim::FluidSimConfig& config, SolverConfig& solver, ViscosityConfig& viscosity);

}  // namespace ros_bridge
}  // namespace fluid_sim
