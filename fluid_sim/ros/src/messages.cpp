#include "fluid_sim/ros/messages.h"

#include <algorithm>
#include <cstring>

namespace fluid_sim
{
namespace ros_bridge
{
namespace
{
void setFields(sensor_msgs::PointCloud2& cloud, const std::vector<std::string>& names, std::size_t points)
{
  cloud.fields.clear();
  for (std::size_t k = 0; k < names.size(); ++k)
  {
    sensor_msgs::PointField f;
    f.name = names[k];
    f.offset = static_cast<std::uint32_t>(4 * k);
    f.datatype = sensor_msgs::PointField::FLOAT32;
    f.count = 1;
    cloud.fields.push_back(f);
  }
  cloud.height = 1;
  cloud.width = static_cast<std::uint32_t>(points);
  cloud.is_bigendian = false;  // x86 and ARM as ROS runs them; rviz reads it as given
  cloud.is_dense = true;       // the solver never hands out NaN positions (it reports instead)
  cloud.point_step = static_cast<std::uint32_t>(4 * names.size());
  cloud.row_step = cloud.point_step * cloud.width;
  cloud.data.resize(static_cast<std::size_t>(cloud.row_step));
}
}  // namespace

void fillParticleCloud(const FluidSnapshot& fluid, std::size_t max_points, sensor_msgs::PointCloud2& cloud)
{
  const std::size_t n = fluid.positions.size();
  const std::size_t stride = (max_points == 0 || n <= max_points) ? 1 : (n + max_points - 1) / max_points;
  const std::size_t count = (n + stride - 1) / stride;
  setFields(cloud, {"x", "y", "z", "vx", "vy", "vz", "pressure", "density", "speed"}, count);
  float* out = reinterpret_cast<float*>(cloud.data.data());
  for (std::size_t i = 0; i < n; i += stride)
  {
    const Vec3& x = fluid.positions[i];
    const Vec3& v = fluid.velocities[i];
    out[0] = float(x.x());
    out[1] = float(x.y());
    out[2] = float(x.z());
    out[3] = float(v.x());
    out[4] = float(v.y());
    out[5] = float(v.z());
    out[6] = float(fluid.pressures[i]);
    out[7] = float(fluid.densities[i]);
    out[8] = float(v.norm());
    out += kParticleFields;
  }
}

void fillBoundaryCloud(const std::vector<Vec3>& positions, const std::vector<Real>& pressures,
                       const std::vector<std::pair<std::size_t, std::size_t>>& body_ranges,
                       sensor_msgs::PointCloud2& cloud)
{
  const std::size_t n = positions.size();
  setFields(cloud, {"x", "y", "z", "pressure", "body"}, n);
  float* out = reinterpret_cast<float*>(cloud.data.data());
  for (std::size_t k = 0; k < body_ranges.size(); ++k)
  {
    const std::size_t end = std::min(n, body_ranges[k].first + body_ranges[k].second);
    for (std::size_t i = body_ranges[k].first; i < end; ++i)
    {
      float* p = out + 5 * i;
      p[0] = float(positions[i].x());
      p[1] = float(positions[i].y());
      p[2] = float(positions[i].z());
      p[3] = pressures.size() == n ? float(pressures[i]) : 0.0f;
      p[4] = float(k);
    }
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

Pose toPose(const geometry_msgs::Transform& transform)
{
  const geometry_msgs::Vector3& t = transform.translation;
  const geometry_msgs::Quaternion& q = transform.rotation;
  return Pose::fromTranslationQuaternion(Vec3d(t.x, t.y, t.z), q.w, q.x, q.y, q.z);
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
  s.step_wall_time = report.ms_total * 1e-3;
  s.real_time_factor = real_time_factor;
  s.paused = paused;
  s.status = status;
  return s;
}

fluid_sim::FluidSimConfig toReconfigure(const SolverConfig& solver, const ViscosityConfig& viscosity)
{
  fluid_sim::FluidSimConfig c;
  c.density_error = solver.density_error;
  c.divergence_error = solver.divergence_error;
  c.min_iterations = solver.min_iterations;
  c.max_iterations = solver.max_iterations;
  c.warm_start = solver.warm_start;
  c.viscosity_model = toString(viscosity.model);
  c.viscosity_coefficient = viscosity.coefficient;
  c.boundary_viscosity = viscosity.boundary;
  const fluid_sim::FluidSimConfig& defaults = fluid_sim::FluidSimConfig::__getDefault__();
  c.publish_rate = defaults.publish_rate;  // only the top-level values of the defaults are set
  c.real_time_factor = defaults.real_time_factor;
  c.max_points = defaults.max_points;
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
  // The .cfg offers exactly these three names.
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
