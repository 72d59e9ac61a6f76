#include "fluid_sim/ros/messages.h"

#include <algorithm>
#include <cstring>

#include <sensor_msgs/point_cloud2_iterator.h>

namespace fluid_sim
{
namespace ros_bridge
{
void fillParticleCloud(const FluidSnapshot& fluid, std::size_t max_points, sensor_msgs::PointCloud2& cloud)
{
  const std::size_t n = fluid.positions.size();
  const std::size_t stride = (max_points == 0 || n <= max_points) ? 1 : (n + max_points - 1) / max_points;
  const std::size_t count = (n + stride - 1) / stride;
  sensor_msgs::PointCloud2Modifier modifier(cloud);
  modifier.setPointCloud2Fields(kParticleFields, "x", 1, sensor_msgs::PointField::FLOAT32, "y", 1,
                                sensor_msgs::PointField::FLOAT32, "z", 1, sensor_msgs::PointField::FLOAT32, "vx", 1,
                                sensor_msgs::PointField::FLOAT32, "vy", 1, sensor_msgs::PointField::FLOAT32, "vz", 1,
                                sensor_msgs::PointField::FLOAT32, "pressure", 1, sensor_msgs::PointField::FLOAT32,
                                "density", 1, sensor_msgs::PointField::FLOAT32, "speed", 1,
                                sensor_msgs::PointField::FLOAT32);
  modifier.resize(count);      // height 1: an unorganised cloud
  cloud.is_bigendian = false;  // x86 and ARM as ROS runs them; rviz reads it as given
  cloud.is_dense = true;       // the solver never hands out NaN positions (it reports instead)
  // x, y, z and vx, vy, vz are consecutive fields: one iterator each, indexed.
  sensor_msgs::PointCloud2Iterator<float> position(cloud, "x"), velocity(cloud, "vx");
  sensor_msgs::PointCloud2Iterator<float> pressure(cloud, "pressure"), density(cloud, "density"), speed(cloud, "speed");
  for (std::size_t i = 0; i < n; i += stride, ++position, ++velocity, ++pressure, ++density, ++speed)
  {
    const Vec3& x = fluid.positions[i];
    const Vec3& v = fluid.velocities[i];
    position[0] = float(x.x());
    position[1] = float(x.y());
    position[2] = float(x.z());
    velocity[0] = float(v.x());
    velocity[1] = float(v.y());
    velocity[2] = float(v.z());
    *pressure = float(fluid.pressures[i]);
    *density = float(fluid.densities[i]);
    *speed = float(v.norm());
  }
}

void fillBoundaryCloud(const std::vector<Vec3>& positions, const std::vector<Real>& pressures,
                       const std::vector<std::pair<std::size_t, std::size_t>>& body_ranges,
                       sensor_msgs::PointCloud2& cloud)
{
  const std::size_t n = positions.size();
  sensor_msgs::PointCloud2Modifier modifier(cloud);
  modifier.setPointCloud2Fields(5, "x", 1, sensor_msgs::PointField::FLOAT32, "y", 1, sensor_msgs::PointField::FLOAT32,
                                "z", 1, sensor_msgs::PointField::FLOAT32, "pressure", 1,
                                sensor_msgs::PointField::FLOAT32, "body", 1, sensor_msgs::PointField::FLOAT32);
  modifier.resize(n);
  cloud.is_bigendian = false;
  cloud.is_dense = true;
  for (std::size_t k = 0; k < body_ranges.size(); ++k)
  {
    const std::size_t first = std::min(n, body_ranges[k].first);
    const std::size_t end = std::min(n, body_ranges[k].first + body_ranges[k].second);
    sensor_msgs::PointCloud2Iterator<float> position(cloud, "x"), pressure(cloud, "pressure"), body(cloud, "body");
    const int skip = static_cast<int>(first);  // the iterators step by points
    position += skip;
    pressure += skip;
    body += skip;
    for (std::size_t i = first; i < end; ++i, ++position, ++pressure, ++body)
    {
      position[0] = float(positions[i].x());
      position[1] = float(positions[i].y());
      position[2] = float(positions[i].z());
      *pressure = pressures.size() == n ? float(pressures[i]) : 0.0f;
      *body = float(k);
    }
  }
}

void fillSurfaceMarker(const SurfaceMesh& mesh, visualization_msgs::Marker& marker)
{
  marker.ns = "surface";
  marker.id = 0;
  marker.type = visualization_msgs::Marker::TRIANGLE_LIST;
  marker.action = mesh.empty() ? visualization_msgs::Marker::DELETE : visualization_msgs::Marker::ADD;
  marker.pose = geometry_msgs::Pose();
  marker.pose.orientation.w = 1.0;  // rviz refuses a zero quaternion
  marker.scale.x = marker.scale.y = marker.scale.z = 1.0;
  marker.color.r = 0.25f;  // water blue, opaque: rviz draws a translucent TRIANGLE_LIST unsorted (the far
  // walls showed through the top in black patches)
  marker.color.g = 0.55f;
  marker.color.b = 0.95f;
  marker.color.a = 1.0f;
  marker.lifetime = ros::Duration(0);  // until the next one (the last one stays while paused)
  marker.frame_locked = false;
  marker.colors.clear();
  marker.points.resize(3 * mesh.triangles.size());
  std::size_t k = 0;
  for (const auto& t : mesh.triangles)
    for (const Index i : t)
    {
      const Vec3& v = mesh.vertices[i];
      geometry_msgs::Point& p = marker.points[k++];
      p.x = double(v.x());
      p.y = double(v.y());
      p.z = double(v.z());
    }
}

geometry_msgs::Wrench toWrench(const Vec3d& force, const Vec3d& torque)
{
  geometry_msgs::Wrench w;
  w.force.x = force.x();
  w.force.y = force.y();
  w.force.z = force.z();
  w.torque.x = torque.x();
  w.torque.y = torque.y();
  w.torque.z = torque.z();
  return w;
}

fluid_msgs::ContactWrench toContactWrench(const BodyInfo& body, const Vec3d& force, const Vec3d& torque,
                                          double max_pressure)
{
  fluid_msgs::ContactWrench cw;
  cw.link = body.name;
  cw.wrench = toWrench(force, torque);
  cw.contact_particles = static_cast<std::uint32_t>(body.contact_particles);
  cw.max_pressure = max_pressure;
  return cw;
}

fluid_msgs::RegionState toRegionState(const RegionMeasurement& m)
{
  fluid_msgs::RegionState r;
  r.name = m.name;
  r.volume = m.volume;
  r.mass = m.mass;
  r.capacity = m.capacity;
  r.fill_fraction = m.fill_fraction;
  r.mean_velocity.x = m.mean_velocity.x();
  r.mean_velocity.y = m.mean_velocity.y();
  r.mean_velocity.z = m.mean_velocity.z();
  r.particles = static_cast<std::uint32_t>(m.particles);
  return r;
}

fluid_msgs::EmitterArray toEmitterArray(const std::vector<EmitterTotal>& emitters, const ros::Time& stamp,
                                        const std::string& frame)
{
  fluid_msgs::EmitterArray out;
  out.header.stamp = stamp;
  out.header.frame_id = frame;
  for (const EmitterTotal& e : emitters)
  {
    fluid_msgs::Emitter m;
    m.name = e.name;
    m.particles = static_cast<std::uint32_t>(e.particles);
    m.blocked = static_cast<std::uint32_t>(e.blocked);
    m.volume = e.volume;
    m.mass = e.mass;
    m.flow_rate = e.flow_rate;
    m.budget_reached = e.budget_reached;
    out.emitters.push_back(m);
  }
  return out;
}

fluid_msgs::SinkArray toSinkArray(const std::vector<SinkTotal>& sinks, const ros::Time& stamp, const std::string& frame)
{
  fluid_msgs::SinkArray out;
  out.header.stamp = stamp;
  out.header.frame_id = frame;
  for (const SinkTotal& s : sinks)
  {
    fluid_msgs::Sink m;
    m.name = s.name;
    m.particles = static_cast<std::uint32_t>(s.particles);
    m.volume = s.volume;
    m.mass = s.mass;
    out.sinks.push_back(m);
  }
  return out;
}

fluid_msgs::Probe toProbe(const ProbeMeasurement& m)
{
  fluid_msgs::Probe p;
  p.name = m.name;
  p.position.x = m.position.x();
  p.position.y = m.position.y();
  p.position.z = m.position.z();
  p.wet = m.wet;
  p.pressure = m.pressure;
  p.density = m.density;
  p.velocity.x = m.velocity.x();
  p.velocity.y = m.velocity.y();
  p.velocity.z = m.velocity.z();
  p.fluid_support = m.fluid_support;
  p.wall_support = m.wall_support;
  return p;
}

Pose toPose(const geometry_msgs::Transform& transform)
{
  const geometry_msgs::Vector3& t = transform.translation;
  const geometry_msgs::Quaternion& q = transform.rotation;
  return Pose::fromTranslationQuaternion(Vec3d(t.x, t.y, t.z), q.w, q.x, q.y, q.z);
}

fluid_msgs::FreeBody toFreeBody(const BodyInfo& body)
{
  fluid_msgs::FreeBody m;
  m.name = body.name;
  m.pose.position.x = body.pose.translation.x();
  m.pose.position.y = body.pose.translation.y();
  m.pose.position.z = body.pose.translation.z();
  const Eigen::Quaterniond q = body.pose.rotation.normalized();
  m.pose.orientation.w = q.w();
  m.pose.orientation.x = q.x();
  m.pose.orientation.y = q.y();
  m.pose.orientation.z = q.z();
  m.center_of_mass.x = body.center_of_mass.x();
  m.center_of_mass.y = body.center_of_mass.y();
  m.center_of_mass.z = body.center_of_mass.z();
  m.twist.linear.x = body.com_velocity.x();
  m.twist.linear.y = body.com_velocity.y();
  m.twist.linear.z = body.com_velocity.z();
  m.twist.angular.x = body.angular_velocity.x();
  m.twist.angular.y = body.angular_velocity.y();
  m.twist.angular.z = body.angular_velocity.z();
  m.fluid_wrench = toWrench(body.force, body.torque_com);
  m.contact_force.x = body.contact_force.x();
  m.contact_force.y = body.contact_force.y();
  m.contact_force.z = body.contact_force.z();
  m.mass = body.mass;
  return m;
}

geometry_msgs::TransformStamped toTransformStamped(const Pose& pose, const std::string& parent,
                                                   const std::string& child, const ros::Time& stamp)
{
  geometry_msgs::TransformStamped t;
  t.header.stamp = stamp;
  t.header.frame_id = parent;
  t.child_frame_id = child;
  t.transform.translation.x = pose.translation.x();
  t.transform.translation.y = pose.translation.y();
  t.transform.translation.z = pose.translation.z();
  const Eigen::Quaterniond q = pose.rotation.normalized();
  t.transform.rotation.w = q.w();
  t.transform.rotation.x = q.x();
  t.transform.rotation.y = q.y();
  t.transform.rotation.z = q.z();
  return t;
}

fluid_msgs::SolverStats toSolverStats(const StepReport& report, const Simulation& sim, double real_time_factor,
                                      bool paused, const std::string& status)
{
  fluid_msgs::SolverStats s;
  s.sim_time = sim.time();
  s.time_step = report.dt;
  s.divergence_iterations = report.divergence_iterations;
  s.density_iterations = report.density_iterations;
  s.density_error = report.density_error;
  s.divergence_error = report.divergence_error;
  s.max_speed = report.max_speed;
  s.fluid_particles = static_cast<std::uint32_t>(sim.numFluidParticles());
  s.removed_particles = static_cast<std::uint32_t>(sim.removedTotal());
  s.wall_guarded = static_cast<std::uint32_t>(report.wall_guarded);
  s.step_wall_time = report.ms_total * 1e-3;
  s.real_time_factor = real_time_factor;
  s.paused = paused;
  s.status = status;
  return s;
}

fluid_sim::FluidSimConfig toReconfigure(const SolverConfig& solver, const ViscosityConfig& viscosity)
{
  // Value-initialised ({}): the generated class has no constructor of its own, so this zeroes
  // every member first, each group's copy of a parameter included. Default-initialised, those
  // copies hold whatever the memory held, and __toMessage__() (fillReconfigureGroups) copies the
  // whole config into a boost::any before it sets them: a load of an indeterminate bool (UBSan:
  // "load of value 64 ... not a valid value for type 'bool'" in Reconfigure's test).
  fluid_sim::FluidSimConfig c{};
  c.density_error = solver.density_error;
  c.divergence_error = solver.divergence_error;
  c.min_iterations = solver.min_iterations;
  c.max_iterations = solver.max_iterations;
  c.warm_start = solver.warm_start;
  c.warm_start_guess = toString(solver.warm_start_guess);
  c.viscosity_model = toString(viscosity.model);
  c.viscosity_coefficient = viscosity.coefficient;
  c.boundary_viscosity = viscosity.boundary;
  const fluid_sim::FluidSimConfig& defaults = fluid_sim::FluidSimConfig::__getDefault__();
  c.publish_rate = defaults.publish_rate;  // only the top-level values of the defaults are set
  c.real_time_factor = defaults.real_time_factor;
  c.max_points = defaults.max_points;
  c.surface_rate = defaults.surface_rate;
  fillReconfigureGroups(c);
  return c;
}

void fillReconfigureGroups(fluid_sim::FluidSimConfig& c)
{
  // The generated __fromMessage__ sets each group's copy from the message's parameters.
  dynamic_reconfigure::Config msg;
  c.__toMessage__(msg);
  c.__fromMessage__(msg);
}

void fromReconfigure(const fluid_sim::FluidSimConfig& config, SolverConfig& solver, ViscosityConfig& viscosity)
{
  solver.density_error = config.density_error;
  solver.divergence_error = config.divergence_error;
  solver.min_iterations = config.min_iterations;
  solver.max_iterations = config.max_iterations;
  solver.warm_start = config.warm_start;
  // The .cfg offers exactly these names.
  solver.warm_start_guess = config.warm_start_guess == "damped" ? WarmStartGuess::Damped : WarmStartGuess::Previous;
  if (config.viscosity_model == "artificial")
    viscosity.model = ViscosityModel::Artificial;
  else if (config.viscosity_model == "xsph")
    viscosity.model = ViscosityModel::Xsph;
  else
    viscosity.model = ViscosityModel::None;
  viscosity.coefficient = config.viscosity_coefficient;
  viscosity.boundary = config.boundary_viscosity;
}

}  // namespace ros_bridge
}  // namespace fluid_sim
