#pragma once
// The node's services (reset, pause, step) and its dynamic_reconfigure server: thin ROS
// adapters. The commands themselves are carried out by the solver loop between two steps;
// max_points and surface_rate go to the publishers.

#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <dynamic_reconfigure/server.h>
#include <ros/node_handle.h>
#include <ros/service_server.h>
#include <std_srvs/SetBool.h>
#include <std_srvs/Trigger.h>
#include <boost/thread/recursive_mutex.hpp>

#include "fluid_msgs/StepSimulation.h"
#include "fluid_sim/FluidSimConfig.h"
#include "fluid_sim/ros/node_parameters.h"
#include "fluid_sim/ros/publishers.h"
#include "fluid_sim/ros/solver_loop.h"

namespace fluid_sim
{
namespace ros_bridge
{
class Services
{
public:
  Services(SolverLoop& loop, Publishers& publishers);

  /// Advertises reset, pause and step in `nh` (the node's namespace, so that they are remapped
  /// as users expect) and starts the dynamic_reconfigure server in `pnh` (the private namespace,
  /// where the parameters it sets live) from the simulation's settings and the node options (not
  /// from the .cfg defaults).
  void advertise(ros::NodeHandle& nh, ros::NodeHandle& pnh, const NodeOptions& opt);

  /// Stops serving reset, pause and step.
  void shutdown();

  /// The resolved names of the services advertised (with dynamic_reconfigure's set_parameters):
  /// what the master watch registers again with a restarted master.
  std::vector<std::string> names() const;

private:
  bool onReset(std_srvs::Trigger::Request& req, std_srvs::Trigger::Response& res);
  bool onPause(std_srvs::SetBool::Request& req, std_srvs::SetBool::Response& res);
  bool onStep(fluid_msgs::StepSimulation::Request& req, fluid_msgs::StepSimulation::Response& res);
  /// Refuses values out of the node's ranges and solver settings the scene's checks refuse
  /// (checkReconfigure: set back, with a warning), then hands the request on. `config` is what
  /// the server then reports.
  void onReconfigure(fluid_sim::FluidSimConfig& config);

  SolverLoop& loop_;
  Publishers& publishers_;
  ros::ServiceServer srv_reset_, srv_pause_, srv_step_;
  std::unique_ptr<dynamic_reconfigure::Server<fluid_sim::FluidSimConfig>> reconfigure_;
  boost::recursive_mutex reconfigure_mutex_;
  fluid_sim::FluidSimConfig current_;  // the settings last accepted (under reconfigure_mutex_)
  SceneConfig scene_;                  // the simulation's scene when advertised: what a request is validated against
  mutable std::mutex names_mutex_;
  std::vector<std::string> names_;  // under names_mutex_
};

}  // namespace ros_bridge
}  // namespace fluid_sim
