#include "fluid_sim/ros/services.h"

#include <algorithm>

#include <ros/console.h>

#include "fluid_sim/ros/messages.h"

namespace fluid_sim
{
namespace ros_bridge
{
Services::Services(SolverLoop& loop, Publishers& publishers) : loop_(loop), publishers_(publishers) {}

void Services::advertise(ros::NodeHandle& nh, ros::NodeHandle& pnh, const NodeOptions& opt)
{
  srv_reset_ = nh.advertiseService("reset", &Services::onReset, this);
  srv_pause_ = nh.advertiseService("pause", &Services::onPause, this);
  srv_step_ = nh.advertiseService("step", &Services::onStep, this);

  reconfigure_ = std::make_unique<dynamic_reconfigure::Server<fluid_sim::FluidSimConfig>>(reconfigure_mutex_, pnh);
  const SceneConfig& s = loop_.simulation().scene();
  fluid_sim::FluidSimConfig cfg = toReconfigure(s.solver, s.viscosity);
  cfg.publish_rate = opt.publish_rate;
  cfg.real_time_factor = opt.real_time_factor;
  cfg.max_points = opt.max_points;
  cfg.surface_rate = opt.surface_rate;
  fillReconfigureGroups(cfg);
  current_ = cfg;
  scene_ = s;
  reconfigure_->updateConfig(cfg);
  reconfigure_->setCallback([this](fluid_sim::FluidSimConfig& c, uint32_t) { onReconfigure(c); });
  std::lock_guard<std::mutex> lock(names_mutex_);
  names_ = {srv_reset_.getService(), srv_pause_.getService(), srv_step_.getService(),
            pnh.resolveName("set_parameters")};
}

std::vector<std::string> Services::names() const
{
  std::lock_guard<std::mutex> lock(names_mutex_);
  return names_;
}

void Services::shutdown()
{
  srv_reset_.shutdown();
  srv_pause_.shutdown();
  srv_step_.shutdown();
}

bool Services::onReset(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res)
{
  const CommandResult r = loop_.reset();
  res.success = r.success;
  res.message = r.message;
  return true;
}

bool Services::onPause(std_srvs::SetBool::Request& req, std_srvs::SetBool::Response& res)
{
  const CommandResult r = loop_.pause(req.data);
  res.success = r.success;
  res.message = r.message;
  return true;
}

bool Services::onStep(fluid_msgs::StepSimulation::Request& req, fluid_msgs::StepSimulation::Response& res)
{
  const CommandResult r = loop_.step(req.steps);
  res.success = r.success;
  res.message = r.message;
  res.sim_time = r.sim_time;
  return true;
}

void Services::onReconfigure(fluid_sim::FluidSimConfig& config)
{
  for (const std::string& w : checkReconfigure(config, current_, &scene_)) ROS_WARN("%s", w.c_str());
  current_ = config;
  publishers_.setMaxPoints(static_cast<std::size_t>(std::max(0, config.max_points)));
  publishers_.setSurfaceRate(config.surface_rate);
  loop_.reconfigure(config);
}

}  // namespace ros_bridge
}  // namespace fluid_sim
