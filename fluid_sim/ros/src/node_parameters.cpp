#include "fluid_sim/ros/node_parameters.h"

#include <algorithm>

#include <ros/console.h>
#include <ros/package.h>
#include <ros/this_node.h>

#include "fluid_sim/io/scene_loader.h"
#include "fluid_sim/io/urdf_loader.h"
#include "fluid_sim/ros/fluid_sim_node.h"
#include "fluid_sim/ros/param_yaml.h"

namespace fluid_sim
{
namespace ros_bridge
{
const std::set<std::string>& nodeKeys()
{
  static const std::set<std::string> keys = {
      "robot_description_param", "fixed_frame", "links", "container_links", "real_time_factor", "publish_rate",
      "max_points", "tf_delay", "tf_wait_timeout", "stop_after", "threads", "publish_boundary",
      // dynamic_reconfigure (cfg/FluidSim.cfg)
      "density_error", "divergence_error", "min_iterations", "max_iterations", "warm_start", "viscosity_model",
      "viscosity_coefficient", "boundary_viscosity", "groups"};
  return keys;
}

NodeOptions readNodeOptions(const ros::NodeHandle& pnh)
{
  NodeOptions opt;
  auto param = [&](const std::string& name, auto& value) { pnh.param(name, value, value); };
  param("robot_description_param", opt.robot_description_param);
  param("fixed_frame", opt.fixed_frame);
  param("links", opt.links);
  param("container_links", opt.container_links);
  param("real_time_factor", opt.real_time_factor);
  param("publish_rate", opt.publish_rate);
  param("max_points", opt.max_points);
  param("tf_delay", opt.tf_delay);
  param("tf_wait_timeout", opt.tf_wait_timeout);
  param("stop_after", opt.stop_after);
  param("threads", opt.threads);
  param("publish_boundary", opt.publish_boundary);
  const std::string ns = pnh.getNamespace();
  auto bad = [&](const std::string& key, const std::string& why) {
    throw StartupError("parameter " + ns + "/" + key + ": " + why);
  };
  if (opt.fixed_frame.empty()) bad("fixed_frame", "must not be empty");
  if (!(opt.real_time_factor >= 0.0)) bad("real_time_factor", "must be >= 0 (0 = as fast as possible)");
  if (!(opt.publish_rate > 0.0)) bad("publish_rate", "must be > 0 Hz");
  if (opt.max_points < 0) bad("max_points", "must be >= 0 (0 = all)");
  if (!(opt.tf_delay >= 0.0)) bad("tf_delay", "must be >= 0 s");
  if (!(opt.tf_wait_timeout >= 0.0)) bad("tf_wait_timeout", "must be >= 0 s (0 = wait for ever)");
  if (!(opt.stop_after >= 0.0)) bad("stop_after", "must be >= 0 s (0 = run until shut down)");
  if (opt.threads < 0) bad("threads", "must be >= 0 (0 = all cores)");
  return opt;
}

SceneConfig readScene(const ros::NodeHandle& pnh)
{
  XmlRpc::XmlRpcValue params;
  const std::string ns = pnh.getNamespace();
  if (!pnh.getParam(ns, params)) params = XmlRpc::XmlRpcValue();
  std::string yaml;
  try
  {
    yaml = sceneYaml(params, nodeKeys());
  }
  catch (const std::invalid_argument& e)
  {
    throw StartupError("parameter " + ns + "/" + e.what());
  }
  io::SceneLoadOptions load;
  load.packages = [](const std::string& pkg) { return ros::package::getPath(pkg); };
  const std::string source = "private parameters of " + ros::this_node::getName();
  SceneConfig scene;
  try
  {
    scene = io::parseScene(yaml, source, {}, load);
  }
  catch (const ConfigError& e)
  {
    throw StartupError(std::string("scene: ") + e.what());
  }
  for (const std::string& w : scene.warnings) ROS_WARN("%s", w.c_str());
  return scene;
}

std::vector<BoundaryConfig> readRobotLinks(const ros::NodeHandle& nh, const ros::NodeHandle& pnh,
                                           const NodeOptions& opt, const SceneConfig& scene)
{
  if (opt.robot_description_param.empty())
  {
    if (!opt.links.empty())
      throw StartupError("parameter " + pnh.getNamespace() +
                         "/links is set but robot_description_param is empty (no robot to take them from)");
    ROS_INFO("robot_description_param is empty: no robot links, only the scene's own bodies");
    return {};
  }
  std::string xml;
  if (!nh.getParam(opt.robot_description_param, xml))
    throw StartupError("missing robot_description: parameter '" + nh.resolveName(opt.robot_description_param) +
                       "' is not set (set it, e.g. with <param name=\"robot_description\" textfile=\"...\"/>, or "
                       "set ~robot_description_param to \"\" to run without a robot)");
  const std::string source = "robot_description (" + nh.resolveName(opt.robot_description_param) + ")";
  try
  {
    const io::UrdfRobot robot = io::parseUrdf(xml, source);
    io::UrdfBoundaryOptions u;
    u.links = opt.links;
    u.spacing = scene.spacing;
    u.packages = [](const std::string& pkg) { return ros::package::getPath(pkg); };
    std::vector<std::string> warnings;
    std::vector<BoundaryConfig> links = io::urdfBoundaries(robot, u, &warnings);
    for (const std::string& w : warnings) ROS_WARN("%s", w.c_str());
    std::set<std::string> names;
    for (const BoundaryConfig& b : links) names.insert(b.name);
    for (const std::string& c : opt.container_links)
    {
      if (!names.count(c))
        throw StartupError("parameter " + pnh.getNamespace() + "/container_links: link '" + c +
                           "' is not among the links used (" + std::to_string(names.size()) +
                           " links with collision geometry)");
    }
    for (BoundaryConfig& b : links)
    {
      b.externally_posed = true;
      b.inside = std::find(opt.container_links.begin(), opt.container_links.end(), b.name) != opt.container_links.end();
      for (const BoundaryConfig& s : scene.boundaries)
        if (s.name == b.name)
          throw StartupError("link '" + b.name + "' has the same name as a body of the scene; rename the scene body");
    }
    return links;
  }
  catch (const ConfigError& e)
  {
    throw StartupError(e.what());
  }
}

}  // namespace ros_bridge
}  // namespace fluid_sim
