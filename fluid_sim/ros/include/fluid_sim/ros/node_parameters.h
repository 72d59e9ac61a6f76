#pragma once
// The node's parameters, read and validated once at start: its own options (NodeOptions), the
// scene (every other private parameter, checked by the strict scene loader through
// param_yaml), and the robot links taken from the URDF. Nothing here is read again later;
// the live settings dynamic_reconfigure changes are held by the solver loop and the publishers.

#include <set>
#include <string>
#include <vector>

#include <ros/node_handle.h>

#include "fluid_sim/core/scene_config.h"

namespace fluid_sim
{
namespace ros_bridge
{
/// The node's own private parameters; every other private parameter is a scene key.
struct NodeOptions
{
  std::string robot_description_param = "robot_description";  // "" = no robot
  std::string fixed_frame = "world";
  std::vector<std::string> links;            // empty = every link with collision geometry
  std::vector<std::string> container_links;  // links that hold water (inside: true)
  double real_time_factor = 1.0;             // 1 (simulated s per ROS s); 1 = tf-coupled, 0 = as fast as it can
  double publish_rate = 30.0;                // Hz
  int max_points = 0;                        // points, particles cloud size limit; 0 = all
  double tf_delay = 0.1;                     // s the simulated instant trails ROS time (rtf 1)
  double tf_wait_timeout = 0.0;              // s to wait for link tf at start; 0 = for ever
  double stop_after = 0.0;                   // s of simulated time, then finish; 0 = never
  int threads = 0;                           // solver threads; 0 = all cores
  bool publish_boundary = true;
};

/// Private parameters that are not scene keys: the node's options, and the values the
/// dynamic_reconfigure server writes back into the private namespace.
const std::set<std::string>& nodeKeys();

/// Reads the node's options from `pnh` (defaults for absent ones) and checks their ranges.
/// Throws StartupError naming the parameter.
NodeOptions readNodeOptions(const ros::NodeHandle& pnh);

/// The scene from the private parameters of `pnh` that are not in nodeKeys(), checked by the
/// scene loader; its warnings are logged. Throws StartupError.
SceneConfig readScene(const ros::NodeHandle& pnh);

/// The robot's links as bodies (shapes in link frames, externally posed; containers marked
/// inside) from the URDF in the parameter opt.robot_description_param of `nh`; empty when that
/// option is "". Sampled at scene.spacing; names must differ from the scene's bodies. Throws
/// StartupError.
std::vector<BoundaryConfig> readRobotLinks(const ros::NodeHandle& nh, const ros::NodeHandle& pnh,
                                           const NodeOptions& opt, const SceneConfig& scene);

}  // namespace ros_bridge
}  // namespace fluid_sim
