#pragma once
// Conversions from the simulation's arrays to ROS messages. Only this layer includes ROS headers.

#include <string>
#include <utility>
#include <vector>

#include <geometry_msgs/Wrench.h>
#include <sensor_msgs/PointCloud2.h>

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

geometry_msgs::Wrench toWrench(const Vec3d& force, const Vec3d& torque);

}  // namespace ros_bridge
}  // namespace fluid_sim
