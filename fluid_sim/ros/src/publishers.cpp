#include "fluid_sim/ros/publishers.h"

#include <algorithm>

#include <geometry_msgs/WrenchStamped.h>

#include "fluid_sim/ros/thread_guard.h"

namespace fluid_sim
{
namespace ros_bridge
{
// ------------------------------------------------------------------------------ WrenchMeans
void WrenchMeans::reset(std::size_t bodies)
{
  bodies_ = bodies;
  steps_.clear();
}

void WrenchMeans::add(const Simulation& sim, double dt)
{
  std::vector<Vec3d> force(sim.numBodies()), torque(sim.numBodies());
  std::vector<double> max_pressure(sim.numBodies());
  for (std::size_t k = 0; k < sim.numBodies(); ++k)
  {
    const BodyInfo b = sim.body(k);
    force[k] = b.force_body;
    torque[k] = b.torque_body;
    max_pressure[k] = b.max_pressure;
  }
  add(dt, force, torque, max_pressure);
}

void WrenchMeans::add(double dt, const std::vector<Vec3d>& force, const std::vector<Vec3d>& torque,
                      const std::vector<double>& max_pressure)
{
  Wrenches st;
  st.force.assign(bodies_, Vec3d::Zero());
  st.torque.assign(bodies_, Vec3d::Zero());
  st.max_pressure.assign(bodies_, 0.0);
  for (std::size_t k = 0; k < bodies_; ++k)
  {
    if (k < force.size()) st.force[k] = force[k];
    if (k < torque.size()) st.torque[k] = torque[k];
    if (k < max_pressure.size()) st.max_pressure[k] = max_pressure[k];
  }
  steps_.add(dt, std::move(st));
}

void WrenchMeans::take(const Simulation& sim, std::vector<fluid_msgs::ContactWrench>& out)
{
  out.resize(sim.numBodies());
  std::vector<Vec3d> force(bodies_, Vec3d::Zero()), torque(bodies_, Vec3d::Zero());
  std::vector<double> max_pressure(bodies_, 0.0);
  const double covered = steps_.take([&](double w, const Wrenches& st) {
    for (std::size_t k = 0; k < bodies_; ++k)
    {
      force[k] += w * st.force[k];
      torque[k] += w * st.torque[k];
      max_pressure[k] = std::max(max_pressure[k], st.max_pressure[k]);
    }
  });
  for (std::size_t k = 0; k < sim.numBodies(); ++k)
  {
    const BodyInfo b = sim.body(k);
    out[k] = covered > 0.0 && k < bodies_ ? toContactWrench(b, force[k] / covered, torque[k] / covered, max_pressure[k])
                                          : toContactWrench(b, b.force_body, b.torque_body, b.max_pressure);
  }
}

// ------------------------------------------------------------------------------ ProbeMeans
void ProbeMeans::add(double dt, const std::vector<ProbeMeasurement>& probes)
{
  std::vector<Reading> readings(probes.size());
  for (std::size_t k = 0; k < probes.size(); ++k)
  {
    const ProbeMeasurement& p = probes[k];
    readings[k] = {p.pressure, p.density, p.velocity, p.fluid_support, p.wall_support};
  }
  // Names and positions are the scene's: copied when the probes first come, not every step.
  if (last_.size() != probes.size()) last_ = probes;
  steps_.add(dt, std::move(readings));
}

std::vector<ProbeMeasurement> ProbeMeans::take()
{
  std::vector<Reading> sum(last_.size());  // each field times s
  const double covered = steps_.take([&](double w, const std::vector<Reading>& readings) {
    for (std::size_t k = 0; k < sum.size() && k < readings.size(); ++k)
    {
      sum[k].pressure += w * readings[k].pressure;
      sum[k].density += w * readings[k].density;
      sum[k].velocity += w * readings[k].velocity;
      sum[k].fluid_support += w * readings[k].fluid_support;
      sum[k].wall_support += w * readings[k].wall_support;
    }
  });
  if (!(covered > 0.0)) return {};  // no step since the reset
  std::vector<ProbeMeasurement> mean = last_;
  for (std::size_t k = 0; k < mean.size(); ++k)
  {
    ProbeMeasurement& m = mean[k];
    m.fluid_support = sum[k].fluid_support / covered;
    m.wall_support = sum[k].wall_support / covered;
    m.density = sum[k].density / covered;
    m.wet = wetness(m.fluid_support, m.wall_support);
    // A mean that is dry reads as a dry step does.
    m.pressure = m.wet ? sum[k].pressure / covered : 0.0;
    m.velocity = m.wet ? Vec3d(sum[k].velocity / covered) : Vec3d::Zero();
  }
  return mean;
}

// ------------------------------------------------------------------------------ Publishers
Publishers::Publishers(const NodeOptions& opt) : opt_(opt) {}

Publishers::~Publishers()
{
  requestStop();
  join();
}

void Publishers::advertise(ros::NodeHandle& nh, const std::vector<BodyTopic>& bodies, const Simulation& sim)
{
  pub_particles_ = nh.advertise<sensor_msgs::PointCloud2>("particles", 2);
  pub_boundary_ = nh.advertise<sensor_msgs::PointCloud2>("boundary_particles", 1, true);
  pub_wrenches_ = nh.advertise<fluid_msgs::ContactWrenchArray>("contact_wrenches", 10);
  pub_stats_ = nh.advertise<fluid_msgs::SolverStats>("stats", 10);
  surface_.advertise(nh, sim.scene().spacing);
  bodies_ = bodies;
  for (const BodyTopic& b : bodies_)
    pub_link_wrench_.push_back(nh.advertise<geometry_msgs::WrenchStamped>(b.topic, 10));
  // Instrument names are ROS base names (validate() refuses others), so they are topic names as
  // they are.
  for (const RegionConfig& r : sim.scene().regions)
    pub_regions_.push_back(nh.advertise<fluid_msgs::RegionState>("regions/" + r.name, 10));
  if (!sim.scene().probes.empty()) pub_probes_ = nh.advertise<fluid_msgs::ProbeArray>("probes", 10);
  if (sim.scene().spill.enabled) pub_spill_ = nh.advertise<fluid_msgs::Spill>("spill", 10);
  if (!sim.scene().sinks.empty()) pub_sinks_ = nh.advertise<fluid_msgs::SinkArray>("sinks", 10);
  if (!sim.scene().emitters.empty()) pub_emitters_ = nh.advertise<fluid_msgs::EmitterArray>("emitters", 10);
  if (std::any_of(bodies.begin(), bodies.end(), [](const BodyTopic& b) { return b.free; }))
    pub_free_ = nh.advertise<fluid_msgs::FreeBodyArray>("free_bodies", 10);

  // Scene bodies are no tf frames of anyone else's: their wrenches are stamped in frames the
  // node publishes, children of the fixed frame at the bodies' poses.
  std::vector<geometry_msgs::TransformStamped> fixed;
  bool any_moving = false;
  for (std::size_t k = 0; k < bodies_.size() && k < sim.numBodies(); ++k)
  {
    if (!bodies_[k].scene_body) continue;
    if (bodies_[k].moving)
      any_moving = true;
    else
      fixed.push_back(toTransformStamped(sim.body(k).pose, opt_.fixed_frame, bodies_[k].frame, ros::Time::now()));
  }
  if (!fixed.empty())
  {
    tf_static_ = std::make_unique<tf2_ros::StaticTransformBroadcaster>();
    tf_static_->sendTransform(fixed);
  }
  if (any_moving) tf_ = std::make_unique<tf2_ros::TransformBroadcaster>();
}

void Publishers::handOver()
{
  {
    std::lock_guard<std::mutex> lock(mutex_);
    std::swap(back_, pending_);
    // A frame the publisher has not taken yet is replaced; keep its boundary cloud if the new
    // one has none (it must not be lost: it is latched and published only when it changes).
    if (!pending_.boundary_valid && back_.boundary_valid)
    {
      std::swap(pending_.boundary, back_.boundary);
      std::swap(pending_.boundary_pressure, back_.boundary_pressure);
      std::swap(pending_.body_ranges, back_.body_ranges);
      pending_.boundary_valid = true;
    }
    back_.boundary_valid = false;
    frame_ready_ = true;
  }
  cv_.notify_one();
}

void Publishers::start()
{
  thread_ = std::thread([this] {
    runGuarded(
        "publisher", [this] { run(); }, on_failure_);
  });
  surface_.start(on_failure_);
}

void Publishers::requestStop()
{
  stopping_ = true;
  cv_.notify_all();
  surface_.requestStop();
}

void Publishers::join()
{
  {
    // The thread may have checked stopping_ just before it was set: wake it once more.
    std::lock_guard<std::mutex> lock(mutex_);
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
  surface_.join();
}

void Publishers::run()
{
  while (true)
  {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      cv_.wait(lock, [&] { return frame_ready_ || stopping_.load(); });
      if (!frame_ready_ && stopping_) return;
      std::swap(front_, pending_);
      pending_.boundary_valid = false;
      frame_ready_ = false;
    }
    const Frame& f = front_;
    if (pub_particles_.getNumSubscribers() > 0)
    {
      // A new message each time: nodelet subscribers may keep the previous one (zero copy).
      boost::shared_ptr<sensor_msgs::PointCloud2> cloud(new sensor_msgs::PointCloud2);
      cloud->header.stamp = f.stamp;
      cloud->header.frame_id = opt_.fixed_frame;
      fillParticleCloud(f.fluid, max_points_, *cloud);
      pub_particles_.publish(cloud);
    }
    surface_.offer(f.stamp, f.fluid.positions);  // when one is due: a copy of the positions, nothing more
    if (f.boundary_valid)
    {
      boost::shared_ptr<sensor_msgs::PointCloud2> cloud(new sensor_msgs::PointCloud2);
      cloud->header.stamp = f.stamp;
      cloud->header.frame_id = opt_.fixed_frame;
      fillBoundaryCloud(f.boundary, f.boundary_pressure, f.body_ranges, *cloud);
      pub_boundary_.publish(cloud);
    }
    if (!f.valid)
    {
      pub_stats_.publish(f.stats);  // says "unstable: <why>"; nothing that reads as a measurement
      continue;
    }
    if (tf_)
    {
      // Before the wrenches stamped in them.
      std::vector<geometry_msgs::TransformStamped> moving;
      for (std::size_t k = 0; k < bodies_.size() && k < f.body_poses.size(); ++k)
        if (bodies_[k].moving)
          moving.push_back(toTransformStamped(f.body_poses[k], opt_.fixed_frame, bodies_[k].frame, f.stamp));
      tf_->sendTransform(moving);
    }
    pub_wrenches_.publish(f.wrenches);
    for (std::size_t k = 0; k < f.wrenches.wrenches.size() && k < pub_link_wrench_.size(); ++k)
    {
      geometry_msgs::WrenchStamped ws;
      ws.header.stamp = f.stamp;
      ws.header.frame_id = bodies_[k].frame;
      ws.wrench = f.wrenches.wrenches[k].wrench;
      pub_link_wrench_[k].publish(ws);
    }
    for (std::size_t k = 0; k < f.regions.size() && k < pub_regions_.size(); ++k) pub_regions_[k].publish(f.regions[k]);
    if (pub_probes_ && !f.probes.probes.empty()) pub_probes_.publish(f.probes);
    if (pub_spill_ && f.spill_valid) pub_spill_.publish(f.spill);
    if (pub_sinks_ && !f.sinks.sinks.empty()) pub_sinks_.publish(f.sinks);
    if (pub_emitters_ && !f.emitters.emitters.empty()) pub_emitters_.publish(f.emitters);
    if (pub_free_ && !f.free_bodies.bodies.empty()) pub_free_.publish(f.free_bodies);
    pub_stats_.publish(f.stats);
  }
}

}  // namespace ros_bridge
}  // namespace fluid_sim
