#pragma once
// The node's parameters, read and validated once at start: its own options (NodeOptions), the
// scene (every other private parameter, checked by the strict scene loader through
// param_yaml), and the robot links taken from the URDF. Nothing here is read again later;
// the live settings dynamic_reconfigure changes are held by the solver loop and the publishers.

#include <set>
#include <string>
#include <vector>

#include <ros/node_handle.h>
#include <xmlrpcpp/XmlRpcValue.h>

#include "fluid_sim/FluidSimConfig.h"
#include "fluid_sim/core/scene_config.h"

namespace fluid_sim
{
namespace ros_bridge
{
/// One entry of ~free_links: a URDF link the simulation moves as a free body.
struct FreeLinkOption
{
  std::string link;
  DynamicConfig dynamic;  // as a scene body's `dynamic` key (enabled = true)
  std::string text;       // the entry's value as YAML, for messages
};

/// The node's own private parameters; every other private parameter is a scene key.
struct NodeOptions
{
  std::string robot_description_param = "robot_description";  // "" = no robot
  std::string fixed_frame = "world";
  std::vector<std::string> links;            // empty = every link with collision geometry
  bool links_given_empty = false;            // ~links was set to [] (warned about: it means every link)
  std::vector<std::string> container_links;  // links that hold water (inside: true)
  std::vector<std::string> thin_links;       // links meant as thin shells (a urdf entry's offset: none)
  std::vector<FreeLinkOption> free_links;    // links that are free bodies, by link name
  double real_time_factor = 1.0;             // 1 (simulated s per ROS s); 1 = tf-coupled, 0 = as fast as it can
  double publish_rate = 30.0;                // Hz
  double surface_rate = 0.0;                 // Hz, free-surface meshes on `surface`; 0 = off
  int max_points = 0;                        // points, particles cloud size limit; 0 = all
  double tf_delay = 0.1;                     // s the simulated instant trails ROS time (rtf 1)
  double tf_wait_timeout = 0.0;              // s to wait for link tf at start; 0 = for ever
  double stop_after = 0.0;                   // s of simulated time, then finish; 0 = never
  int threads = 0;                           // solver threads; 0 = all cores
  bool publish_boundary = true;
  double wrench_window = 0.1;  // s of simulated time each published wrench averages
  double probe_window = 0.1;   // s of simulated time each published probe reading averages
  // s of ROS time the node keeps its own record of the links' poses for, when the simulation falls
  // behind by more than tf keeps (LinkPoses::keepHistory); 0 = tf's 60 s only (links posed at most
  // 30 s back)
  double pose_history = 600.0;
};

/// The checked ranges of the node's numeric parameters (README "The ROS node"). Values outside
/// them would make ros::Duration throw in the solver thread (a real-time factor of 1e-12 turns
/// a 4 ms step into 4e9 s of ROS time) or allocate without bound.
namespace ranges
{
constexpr double kMinRealTimeFactor = 1e-3;  // besides 0 (as fast as it can)
constexpr double kMaxRealTimeFactor = 100.0;
constexpr double kMinPublishRate = 0.1;  // Hz
constexpr double kMaxPublishRate = 1000.0;
constexpr double kMaxSurfaceRate = 100.0;  // Hz (besides 0: off); a mesh takes milliseconds to tens of them
constexpr int kMaxPoints = 100000000;
constexpr double kMaxTfDelay = 30.0;           // s
constexpr double kMaxTfWaitTimeout = 86400.0;  // s
constexpr double kMaxPoseHistory = 86400.0;    // s; 56 B per frame every 10 ms: 480 MB per frame for a day
constexpr double kMaxStopAfter = 1.0e6;        // s of simulated time
constexpr int kMaxThreads = 1024;
constexpr double kMaxWrenchWindow = 10.0;  // s of simulated time
constexpr double kMaxProbeWindow = 10.0;   // s of simulated time
}  // namespace ranges

/// Checks the ranges of `opt`; throws StartupError naming the parameter (under namespace `ns`)
/// and its value.
void checkNodeOptions(const NodeOptions& opt, const std::string& ns);

/// Checks a dynamic_reconfigure request (already clamped to the .cfg's ranges by the server,
/// but a NaN passes that, a real-time factor just above 0 is in range there, and the server
/// takes any string for an enum): each value out of the node's range, and a warm_start_guess or
/// viscosity_model that is not one of the .cfg's names, is set back to its value in `current`,
/// and one warning per refused value (naming it and the value) is returned. With `scene` (the
/// simulation's scene), the solver and viscosity settings that result are also checked as the
/// solver will check them (validate(), e.g. min_iterations above max_iterations); if it refuses
/// them, all of them are set back to `current`'s, with one warning giving its reason, so that
/// the server reports the settings in effect.
std::vector<std::string> checkReconfigure(fluid_sim::FluidSimConfig& requested,
                                          const fluid_sim::FluidSimConfig& current, const SceneConfig* scene = nullptr);

/// Private parameters that are not scene keys: the node's options, and the values the
/// dynamic_reconfigure server writes back into the private namespace.
const std::set<std::string>& nodeKeys();

/// The node's parameters in one map: the top-level keys of the scene file that ~scene_file
/// names (if set), with the private parameters on top (a private parameter wins over the file).
struct NodeParameters
{
  XmlRpc::XmlRpcValue values;  // a struct (or invalid when there is nothing at all)
  std::string ns;              // the private namespace, e.g. /fluid_sim
  std::string scene_file;      // the resolved path of ~scene_file; "" without one
};

/// Reads the private parameters of `pnh` and the scene file named by ~scene_file (an absolute
/// path, package://pkg/path or file:///path; read afresh at every start). Throws StartupError
/// naming the parameter or the file.
NodeParameters readNodeParameters(const ros::NodeHandle& pnh);

/// The node's options from `params` (defaults for absent ones), type- and range-checked.
/// Throws StartupError naming the parameter.
NodeOptions readNodeOptions(const NodeParameters& params);

/// ~free_links, a map {link: {density | mass, inertia, center_of_mass, linear_velocity,
/// angular_velocity}} (the keys and units of a scene body's `dynamic`), read and type-checked.
/// Throws StartupError naming the parameter (under namespace `ns`), the link and the value.
std::vector<FreeLinkOption> readFreeLinks(const XmlRpc::XmlRpcValue& value, const std::string& ns);

/// Makes the links named in `free` free bodies among `links` (the robot's bodies): not posed
/// from tf any more (externally_posed false), their `dynamic` set, starting from the pose they
/// have in `links` (the URDF's, with every joint at 0 and the root link at the fixed frame's
/// origin). The values are checked as the scene's `dynamic` is (with `scene`'s settings). An
/// unknown link, a container link or a bad value throws StartupError naming the parameter (under
/// namespace `ns`), the link and the value.
void applyFreeLinks(const std::vector<FreeLinkOption>& free, std::vector<BoundaryConfig>& links,
                    const SceneConfig& scene, const std::string& ns);

/// Throws StartupError naming `param` (the parameter's full name) and the link for the first name
/// in `listed` that is not the name of one of `links` (the robot's bodies), listing those.
void checkListedLinks(const std::vector<std::string>& listed, const std::vector<BoundaryConfig>& links,
                      const std::string& param);

/// `text` without the scene loader's " (line N)" marks: the node's scene is YAML made from the
/// parameter server, whose lines are no file's.
std::string withoutYamlLines(const std::string& text);

/// The text of a scene loader error (`what`, for the key `key`) as the node reports it: without
/// line marks, and for an unknown top-level key nearer a node parameter than any scene key, with
/// that parameter as the suggestion.
std::string sceneErrorText(const std::string& what, const std::string& key);

/// The scene from the keys of `params` that are not in nodeKeys(), checked by the scene loader;
/// relative file names in it resolve against the scene file's folder (the working directory
/// without ~scene_file). Its warnings are logged. Throws StartupError.
SceneConfig readScene(const NodeParameters& params);

/// YAML text as parameter values, as `rosparam load` makes them (a quoted scalar stays a
/// string; true/false are booleans, whole numbers int, other numbers double, .nan and .inf
/// included). Throws std::invalid_argument for text that is not YAML.
XmlRpc::XmlRpcValue yamlToParameters(const std::string& yaml_text);

/// The robot's links as bodies (shapes in link frames, externally posed; containers marked
/// inside) from the URDF in the parameter opt.robot_description_param, searched for from the
/// namespace of `nh` upwards (an absolute name: that parameter); empty when that option is "". Sampled at
/// scene.spacing; names must differ from the scene's bodies. Throws StartupError.
std::vector<BoundaryConfig> readRobotLinks(const ros::NodeHandle& nh, const ros::NodeHandle& pnh,
                                           const NodeOptions& opt, const SceneConfig& scene);

}  // namespace ros_bridge
}  // namespace fluid_sim
