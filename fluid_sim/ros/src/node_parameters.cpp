#include "fluid_sim/ros/node_parameters.h"

#include <algorithm>
#include <cmath>
#include <sstream>

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

namespace
{
std::string number(double v)
{
  std::ostringstream os;
  os << v;
  return os.str();
}

bool realTimeFactorOk(double rtf)
{
  return rtf == 0.0 || (rtf >= ranges::kMinRealTimeFactor && rtf <= ranges::kMaxRealTimeFactor);
}

const std::string kRealTimeFactorRange = "must be 0 (as fast as it can) or in [" + number(ranges::kMinRealTimeFactor) +
                                         ", " + number(ranges::kMaxRealTimeFactor) + "]";
}  // namespace

void checkNodeOptions(const NodeOptions& opt, const std::string& ns)
{
  auto bad = [&](const std::string& key, double value, const std::string& why) {
    throw StartupError("parameter " + ns + "/" + key + " = " + number(value) + ": " + why);
  };
  // Written as !(in range) so that NaN is refused too.
  auto range = [&](const std::string& key, double value, double lo, double hi, const std::string& unit) {
    if (!(value >= lo && value <= hi))
      bad(key, value, "out of range [" + number(lo) + ", " + number(hi) + "]" + (unit.empty() ? "" : " " + unit));
  };
  if (opt.fixed_frame.empty()) throw StartupError("parameter " + ns + "/fixed_frame: must not be empty");
  if (!realTimeFactorOk(opt.real_time_factor)) bad("real_time_factor", opt.real_time_factor, kRealTimeFactorRange);
  range("publish_rate", opt.publish_rate, ranges::kMinPublishRate, ranges::kMaxPublishRate, "Hz");
  range("max_points", opt.max_points, 0, ranges::kMaxPoints, "(0 = all)");
  range("tf_delay", opt.tf_delay, 0.0, ranges::kMaxTfDelay, "s");
  range("tf_wait_timeout", opt.tf_wait_timeout, 0.0, ranges::kMaxTfWaitTimeout, "s (0 = wait for ever)");
  range("stop_after", opt.stop_after, 0.0, ranges::kMaxStopAfter, "s (0 = run until shut down)");
  range("threads", opt.threads, 0, ranges::kMaxThreads, "(0 = all cores)");
}

std::vector<std::string> checkReconfigure(fluid_sim::FluidSimConfig& requested,
                                          const fluid_sim::FluidSimConfig& current)
{
  std::vector<std::string> warnings;
  auto refuse = [&](const std::string& key, double value, const std::string& why, double kept) {
    warnings.push_back("dynamic_reconfigure: " + key + " = " + number(value) + " refused (" + why + "); keeping " +
                       number(kept));
  };
  auto finite = [&](const std::string& key, double& value, double kept) {
    if (std::isfinite(value)) return;
    refuse(key, value, "not a finite number", kept);
    value = kept;
  };
  if (!realTimeFactorOk(requested.real_time_factor))
  {
    refuse("real_time_factor", requested.real_time_factor, kRealTimeFactorRange, current.real_time_factor);
    requested.real_time_factor = current.real_time_factor;
  }
  if (!(requested.publish_rate >= ranges::kMinPublishRate && requested.publish_rate <= ranges::kMaxPublishRate))
  {
    refuse("publish_rate", requested.publish_rate,
           "must be in [" + number(ranges::kMinPublishRate) + ", " + number(ranges::kMaxPublishRate) + "] Hz",
           current.publish_rate);
    requested.publish_rate = current.publish_rate;
  }
  if (requested.max_points < 0 || requested.max_points > ranges::kMaxPoints)
  {
    refuse("max_points", requested.max_points, "must be in [0, " + number(ranges::kMaxPoints) + "]",
           current.max_points);
    requested.max_points = current.max_points;
  }
  finite("density_error", requested.density_error, current.density_error);
  finite("divergence_error", requested.divergence_error, current.divergence_error);
  finite("viscosity_coefficient", requested.viscosity_coefficient, current.viscosity_coefficient);
  finite("boundary_viscosity", requested.boundary_viscosity, current.boundary_viscosity);
  return warnings;
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
  checkNodeOptions(opt, pnh.getNamespace());
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
