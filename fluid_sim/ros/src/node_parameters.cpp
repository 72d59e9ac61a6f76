#include "fluid_sim/ros/node_parameters.h"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <regex>
#include <sstream>

#include <ros/console.h>
#include <ros/package.h>
#include <ros/this_node.h>
#include <yaml-cpp/yaml.h>

#include "fluid_sim/io/file_util.h"
#include "fluid_sim/io/message_names.h"
#include "fluid_sim/io/resource_resolver.h"
#include "fluid_sim/io/scene_loader.h"
#include "fluid_sim/io/urdf_loader.h"
#include "fluid_sim/ros/fluid_sim_node.h"
#include "fluid_sim/ros/messages.h"
#include "fluid_sim/ros/param_yaml.h"

namespace fluid_sim
{
namespace ros_bridge
{
const std::set<std::string>& nodeKeys()
{
  static const std::set<std::string> keys = {
      "scene_file", "robot_description_param", "fixed_frame", "links", "container_links", "thin_links", "free_links",
      "real_time_factor", "publish_rate", "surface_rate", "max_points", "tf_delay", "tf_wait_timeout", "pose_history",
      "stop_after", "threads", "publish_boundary", "wrench_window", "probe_window",
      // dynamic_reconfigure (cfg/FluidSim.cfg)
      "density_error", "divergence_error", "min_iterations", "max_iterations", "warm_start", "warm_start_guess",
      "viscosity_model", "viscosity_coefficient", "boundary_viscosity", "groups"};
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
  range("surface_rate", opt.surface_rate, 0.0, ranges::kMaxSurfaceRate, "Hz (0 = off)");
  range("max_points", opt.max_points, 0, ranges::kMaxPoints, "(0 = all)");
  range("tf_delay", opt.tf_delay, 0.0, ranges::kMaxTfDelay, "s");
  range("tf_wait_timeout", opt.tf_wait_timeout, 0.0, ranges::kMaxTfWaitTimeout, "s (0 = wait for ever)");
  range("pose_history", opt.pose_history, 0.0, ranges::kMaxPoseHistory, "s (0 = tf's 60 s only)");
  range("stop_after", opt.stop_after, 0.0, ranges::kMaxStopAfter, "s (0 = run until shut down)");
  range("threads", opt.threads, 0, ranges::kMaxThreads, "(0 = all cores)");
  range("wrench_window", opt.wrench_window, 0.0, ranges::kMaxWrenchWindow, "s (0 = the steps since the last message)");
  range("probe_window", opt.probe_window, 0.0, ranges::kMaxProbeWindow, "s (0 = the state of each message's step)");
}

std::vector<std::string> checkReconfigure(fluid_sim::FluidSimConfig& requested,
                                          const fluid_sim::FluidSimConfig& current, const SceneConfig* scene)
{
  std::vector<std::string> warnings;
  // dynamic_reconfigure clamps every field of a request to the .cfg's range, also the ones the
  // caller left alone, and the server starts from the scene's values, which may lie outside it (a
  // scene's max_iterations 20000, a density_error 1e-9): a publish_rate change silently cut them
  // to the range. A field whose request is the clamp of its current value outside the range was
  // not changed by the caller; it keeps its value.
  {
    const fluid_sim::FluidSimConfig& lo = fluid_sim::FluidSimConfig::__getMin__();
    const fluid_sim::FluidSimConfig& hi = fluid_sim::FluidSimConfig::__getMax__();
    auto unclamp = [](auto& value, auto kept, auto min, auto max) {
      if ((kept < min && value == min) || (kept > max && value == max)) value = kept;
    };
    unclamp(requested.density_error, current.density_error, lo.density_error, hi.density_error);
    unclamp(requested.divergence_error, current.divergence_error, lo.divergence_error, hi.divergence_error);
    unclamp(requested.min_iterations, current.min_iterations, lo.min_iterations, hi.min_iterations);
    unclamp(requested.max_iterations, current.max_iterations, lo.max_iterations, hi.max_iterations);
    unclamp(requested.viscosity_coefficient, current.viscosity_coefficient, lo.viscosity_coefficient,
            hi.viscosity_coefficient);
    unclamp(requested.boundary_viscosity, current.boundary_viscosity, lo.boundary_viscosity, hi.boundary_viscosity);
    unclamp(requested.publish_rate, current.publish_rate, lo.publish_rate, hi.publish_rate);
    unclamp(requested.real_time_factor, current.real_time_factor, lo.real_time_factor, hi.real_time_factor);
    unclamp(requested.max_points, current.max_points, lo.max_points, hi.max_points);
    unclamp(requested.surface_rate, current.surface_rate, lo.surface_rate, hi.surface_rate);
  }
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
  if (!(requested.surface_rate >= 0.0 && requested.surface_rate <= ranges::kMaxSurfaceRate))
  {
    refuse("surface_rate", requested.surface_rate,
           "must be in [0, " + number(ranges::kMaxSurfaceRate) + "] Hz (0 = off)", current.surface_rate);
    requested.surface_rate = current.surface_rate;
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
  // The .cfg declares these as enums, but the server passes any string through.
  auto oneOf = [&](const std::string& key, std::string& value, std::initializer_list<const char*> names,
                   const std::string& kept) {
    for (const char* name : names)
      if (value == name) return;
    std::string list;
    for (const char* name : names) list += std::string(list.empty() ? "" : ", ") + name;
    warnings.push_back("dynamic_reconfigure: " + key + " = '" + value + "' refused (must be one of " + list +
                       "); keeping '" + kept + "'");
    value = kept;
  };
  oneOf("warm_start_guess", requested.warm_start_guess, {"previous", "damped"}, current.warm_start_guess);
  oneOf("viscosity_model", requested.viscosity_model, {"none", "artificial", "xsph"}, current.viscosity_model);
  if (scene)
  {
    // What the solver loop will hand Simulation::updateSettings(), checked here, before the server
    // reports the request back: a refusal there would come after the server had reported it.
    SceneConfig next = *scene;
    fromReconfigure(requested, next.solver, next.viscosity);
    try
    {
      validate(next);
    }
    catch (const ConfigError& e)
    {
      warnings.push_back(std::string("dynamic_reconfigure: solver settings refused (") + e.what() +
                         "); keeping the previous ones");
      requested.density_error = current.density_error;
      requested.divergence_error = current.divergence_error;
      requested.min_iterations = current.min_iterations;
      requested.max_iterations = current.max_iterations;
      requested.warm_start = current.warm_start;
      requested.warm_start_guess = current.warm_start_guess;
      requested.viscosity_model = current.viscosity_model;
      requested.viscosity_coefficient = current.viscosity_coefficient;
      requested.boundary_viscosity = current.boundary_viscosity;
    }
  }
  return warnings;
}

namespace
{
XmlRpc::XmlRpcValue toParameter(const YAML::Node& n)
{
  XmlRpc::XmlRpcValue v;
  switch (n.Type())
  {
    case YAML::NodeType::Scalar:
    {
      const std::string& text = n.Scalar();
      if (n.Tag() == "!") return XmlRpc::XmlRpcValue(text);  // quoted: a string
      if (text == "true" || text == "True" || text == "TRUE") return XmlRpc::XmlRpcValue(true);
      if (text == "false" || text == "False" || text == "FALSE") return XmlRpc::XmlRpcValue(false);
      errno = 0;
      char* end = nullptr;
      const long long i = std::strtoll(text.c_str(), &end, 10);
      if (!text.empty() && *end == '\0' && errno == 0 && i >= std::numeric_limits<int>::min() &&
          i <= std::numeric_limits<int>::max())
        return XmlRpc::XmlRpcValue(static_cast<int>(i));
      double d = 0.0;
      if (YAML::convert<double>::decode(n, d)) return XmlRpc::XmlRpcValue(d);
      return XmlRpc::XmlRpcValue(text);
    }
    case YAML::NodeType::Sequence:
      v.setSize(static_cast<int>(n.size()));
      for (std::size_t k = 0; k < n.size(); ++k) v[static_cast<int>(k)] = toParameter(n[k]);
      return v;
    case YAML::NodeType::Map:
      for (const auto& kv : n) v[kv.first.as<std::string>()] = toParameter(kv.second);
      return v;
    default:
      return v;  // null: invalid, which the scene YAML writes as null
  }
}

/// A number parameter (rosparam makes 500 an int, 500.0 a double).
bool asNumber(XmlRpc::XmlRpcValue& v, double& out)
{
  if (v.getType() == XmlRpc::XmlRpcValue::TypeDouble)
    out = static_cast<double>(v);
  else if (v.getType() == XmlRpc::XmlRpcValue::TypeInt)
    out = static_cast<int>(v);
  else
    return false;
  return true;
}

/// Typed reads from the parameter map; a value of the wrong type is an error naming it.
class ParameterReader
{
public:
  explicit ParameterReader(const NodeParameters& p) : p_(p) {}

  template <typename T>
  void read(const std::string& key, T& out) const
  {
    auto& values = const_cast<XmlRpc::XmlRpcValue&>(p_.values);  // accessors are non-const; nothing is changed
    if (values.getType() != XmlRpc::XmlRpcValue::TypeStruct || !values.hasMember(key)) return;
    XmlRpc::XmlRpcValue& v = values[key];
    if (!convert(v, out)) bad(key, v);
  }

private:
  static bool convert(XmlRpc::XmlRpcValue& v, std::string& out)
  {
    if (v.getType() != XmlRpc::XmlRpcValue::TypeString) return false;
    out = static_cast<std::string>(v);
    return true;
  }
  static bool convert(XmlRpc::XmlRpcValue& v, double& out)
  {
    return asNumber(v, out);
  }
  static bool convert(XmlRpc::XmlRpcValue& v, int& out)
  {
    if (v.getType() != XmlRpc::XmlRpcValue::TypeInt) return false;
    out = static_cast<int>(v);
    return true;
  }
  static bool convert(XmlRpc::XmlRpcValue& v, bool& out)
  {
    if (v.getType() != XmlRpc::XmlRpcValue::TypeBoolean) return false;
    out = static_cast<bool>(v);
    return true;
  }
  static bool convert(XmlRpc::XmlRpcValue& v, std::vector<std::string>& out)
  {
    if (v.getType() != XmlRpc::XmlRpcValue::TypeArray) return false;
    std::vector<std::string> list;
    for (int k = 0; k < v.size(); ++k)
    {
      if (v[k].getType() != XmlRpc::XmlRpcValue::TypeString) return false;
      list.push_back(static_cast<std::string>(v[k]));
    }
    out = list;
    return true;
  }

  [[noreturn]] void bad(const std::string& key, const XmlRpc::XmlRpcValue& v) const
  {
    throw StartupError("parameter " + p_.ns + "/" + key + ": a value of the wrong type (" + toYaml(v) + ")" +
                       (p_.scene_file.empty() ? "" : " (parameters and " + p_.scene_file + ")"));
  }

  const NodeParameters& p_;
};
}  // namespace

XmlRpc::XmlRpcValue yamlToParameters(const std::string& yaml_text)
{
  try
  {
    return toParameter(YAML::Load(yaml_text));
  }
  catch (const YAML::Exception& e)
  {
    throw std::invalid_argument(e.what());
  }
}

namespace
{
/// A list of exactly N numbers.
template <std::size_t N>
bool asNumbers(XmlRpc::XmlRpcValue& v, std::array<double, N>& out)
{
  if (v.getType() != XmlRpc::XmlRpcValue::TypeArray || v.size() != static_cast<int>(N)) return false;
  for (std::size_t k = 0; k < N; ++k)
    if (!asNumber(v[static_cast<int>(k)], out[k])) return false;
  return true;
}

std::string yamlOrPlaceholder(const XmlRpc::XmlRpcValue& v)
{
  try
  {
    return toYaml(v);
  }
  catch (const std::invalid_argument&)
  {
    return "(a value that is no YAML)";
  }
}
}  // namespace

std::vector<FreeLinkOption> readFreeLinks(const XmlRpc::XmlRpcValue& value, const std::string& ns)
{
  const std::string param = "parameter " + ns + "/free_links";
  auto& all = const_cast<XmlRpc::XmlRpcValue&>(value);  // accessors are non-const; nothing is changed
  if (all.getType() != XmlRpc::XmlRpcValue::TypeStruct)
    throw StartupError(param + " = " + yamlOrPlaceholder(all) +
                       ": must be a map {link: {density: kg/m^3}} (or {link: {mass: kg, ...}})");
  std::vector<FreeLinkOption> out;
  for (auto it = all.begin(); it != all.end(); ++it)
  {
    FreeLinkOption f;
    f.link = it->first;
    XmlRpc::XmlRpcValue& entry = it->second;
    f.text = yamlOrPlaceholder(entry);
    auto bad = [&](const std::string& why) {
      throw StartupError(param + ": link '" + f.link + "' = " + f.text + ": " + why);
    };
    if (entry.getType() != XmlRpc::XmlRpcValue::TypeStruct)
      bad("must be a map with density (kg/m^3) or mass (kg), as a scene body's dynamic key");
    DynamicConfig& d = f.dynamic;
    d.enabled = true;
    for (auto k = entry.begin(); k != entry.end(); ++k)
    {
      const std::string& key = k->first;
      XmlRpc::XmlRpcValue& v = k->second;
      std::array<double, 3> v3{};
      if (key == "density" || key == "mass")
      {
        if (!asNumber(v, key == "density" ? d.density : d.mass)) bad(key + " must be a number");
      }
      else if (key == "inertia")
      {
        std::array<double, 6> i{};
        if (!asNumbers(v, i)) bad("inertia must be 6 numbers [ixx, iyy, izz, ixy, ixz, iyz] (kg m^2)");
        d.inertia = i;
      }
      else if (key == "center_of_mass" || key == "linear_velocity" || key == "angular_velocity")
      {
        if (!asNumbers(v, v3)) bad(key + " must be 3 numbers [x, y, z]");
        const Vec3d x(v3[0], v3[1], v3[2]);
        if (key == "center_of_mass")
          d.center_of_mass = x;  // m, link frame
        else if (key == "linear_velocity")
          d.linear_velocity = x;  // m/s, fixed frame
        else
          d.angular_velocity = x;  // rad/s, fixed frame
      }
      else
        bad("unknown key '" + key +
            "' (keys: density, mass, inertia, center_of_mass, linear_velocity, angular_velocity)");
    }
    out.push_back(std::move(f));
  }
  return out;
}

void applyFreeLinks(const std::vector<FreeLinkOption>& free, std::vector<BoundaryConfig>& links,
                    const SceneConfig& scene, const std::string& ns)
{
  const std::string param = "parameter " + ns + "/free_links";
  for (const FreeLinkOption& f : free)
  {
    auto bad = [&](const std::string& why) {
      throw StartupError(param + ": link '" + f.link + "' = " + f.text + ": " + why);
    };
    const auto body =
        std::find_if(links.begin(), links.end(), [&](const BoundaryConfig& b) { return b.name == f.link; });
    if (body == links.end())
    {
      std::string names;
      for (const BoundaryConfig& b : links) names += (names.empty() ? "" : ", ") + b.name;
      bad("is not among the links used (" + std::to_string(links.size()) +
          " links with collision geometry: " + (names.empty() ? "none" : names) + ")");
    }
    if (body->inside) bad("is a container (~container_links): a container cannot be a free body");
    body->externally_posed = false;
    body->dynamic = f.dynamic;
    // Checks made when the bodies are built (a centre of mass beyond the body, a body too light)
    // name this key; without it they named boundaries[i].dynamic, which the user never wrote.
    body->dynamic_key = ns + "/free_links/" + f.link;
    // The same checks as a scene body's dynamic key (core validate()), on the link alone.
    SceneConfig check = scene;
    check.boundaries = {*body};
    try
    {
      validate(check);
    }
    catch (const ConfigError& e)
    {
      // The key below the link's dynamic entry ("inertia"), if the fault is in one.
      const std::string& key = e.key();
      const std::size_t at = key.find(".dynamic.");
      bad((at == std::string::npos ? "" : key.substr(at + 9) + ": ") + e.message());
    }
  }
}

void checkListedLinks(const std::vector<std::string>& listed, const std::vector<BoundaryConfig>& links,
                      const std::string& param)
{
  for (const std::string& name : listed)
  {
    if (std::any_of(links.begin(), links.end(), [&](const BoundaryConfig& b) { return b.name == name; })) continue;
    std::string names;
    for (const BoundaryConfig& b : links) names += (names.empty() ? "" : ", ") + b.name;
    throw StartupError("parameter " + param + ": link '" + name + "' is not among the links used (" +
                       std::to_string(links.size()) +
                       " links with collision geometry: " + (names.empty() ? "none" : names) + ")");
  }
}

NodeParameters readNodeParameters(const ros::NodeHandle& pnh)
{
  NodeParameters p;
  p.ns = pnh.getNamespace();
  XmlRpc::XmlRpcValue params;
  if (!pnh.getParam(p.ns, params) || params.getType() != XmlRpc::XmlRpcValue::TypeStruct)
    params = XmlRpc::XmlRpcValue();
  std::string uri;
  if (params.getType() == XmlRpc::XmlRpcValue::TypeStruct && params.hasMember("scene_file"))
  {
    if (params["scene_file"].getType() != XmlRpc::XmlRpcValue::TypeString)
      throw StartupError("parameter " + p.ns + "/scene_file: must be a string (a file path or package:// URI)");
    uri = static_cast<std::string>(params["scene_file"]);
  }
  if (!uri.empty())
  {
    try
    {
      p.scene_file = io::resolveResource(uri, "", [](const std::string& pkg) { return ros::package::getPath(pkg); });
      XmlRpc::XmlRpcValue file;
      try
      {
        file = yamlToParameters(io::readTextFile(p.scene_file, "scene file"));
      }
      catch (const std::invalid_argument& e)
      {
        throw StartupError(p.scene_file + ": not valid YAML: " + e.what());
      }
      if (file.getType() != XmlRpc::XmlRpcValue::TypeStruct)
        throw StartupError(p.scene_file + ": a scene file is a map of keys (README, Scene keys)");
      p.values = file;
    }
    catch (const ConfigError& e)
    {
      // roslaunch reads scene:=tank.yaml from the folder it was started in, the node from its own
      // working folder (~/.ros by default): say so, or the "no such file" reads as a lie.
      const bool relative =
          !uri.empty() && uri[0] != '/' && uri.rfind("package://", 0) != 0 && uri.rfind("file://", 0) != 0;
      throw StartupError("parameter " + p.ns + "/scene_file: " + e.what() +
                         (relative ? " (a relative path is taken from the node's working folder, " +
                                         std::filesystem::current_path().string() +
                                         ", not from where roslaunch was started: give an absolute path or a "
                                         "package:// URI)"
                                   : std::string()));
    }
  }
  if (params.getType() == XmlRpc::XmlRpcValue::TypeStruct)
    for (auto it = params.begin(); it != params.end(); ++it) p.values[it->first] = it->second;
  return p;
}

NodeOptions readNodeOptions(const NodeParameters& params)
{
  NodeOptions opt;
  const ParameterReader r(params);
  r.read("robot_description_param", opt.robot_description_param);
  r.read("fixed_frame", opt.fixed_frame);
  r.read("links", opt.links);
  {
    auto& values = const_cast<XmlRpc::XmlRpcValue&>(params.values);  // accessors are non-const; nothing is changed
    opt.links_given_empty =
        values.getType() == XmlRpc::XmlRpcValue::TypeStruct && values.hasMember("links") && opt.links.empty();
  }
  r.read("container_links", opt.container_links);
  r.read("thin_links", opt.thin_links);
  r.read("real_time_factor", opt.real_time_factor);
  r.read("publish_rate", opt.publish_rate);
  r.read("surface_rate", opt.surface_rate);
  r.read("max_points", opt.max_points);
  r.read("tf_delay", opt.tf_delay);
  r.read("tf_wait_timeout", opt.tf_wait_timeout);
  r.read("pose_history", opt.pose_history);
  r.read("stop_after", opt.stop_after);
  r.read("threads", opt.threads);
  r.read("publish_boundary", opt.publish_boundary);
  r.read("wrench_window", opt.wrench_window);
  r.read("probe_window", opt.probe_window);
  if (params.values.getType() == XmlRpc::XmlRpcValue::TypeStruct && params.values.hasMember("free_links"))
  {
    auto& values = const_cast<XmlRpc::XmlRpcValue&>(params.values);  // accessors are non-const
    opt.free_links = readFreeLinks(values["free_links"], params.ns);
  }
  checkNodeOptions(opt, params.ns);
  return opt;
}

std::string withoutYamlLines(const std::string& text)
{
  // The loader reads YAML made from the parameter server (sceneYaml), not the scene file: its
  // line numbers point at nothing a user can open. (A URDF's "(URDF line N)" is the URDF's own.)
  static const std::regex line(" \\(line [0-9]+\\)");
  return std::regex_replace(text, line, "");
}

std::string sceneErrorText(const std::string& what, const std::string& key)
{
  std::string text = withoutYamlLines(what);
  // A misspelt node parameter reaches the scene loader as an unknown top-level scene key, whose
  // hint lists scene keys only: suggest the node parameter when it is the nearer name.
  if (key.empty() || key.find_first_of(".[") != std::string::npos) return text;
  const std::string unknown = key + ": unknown key";
  const std::size_t at = text.find(unknown);
  if (at == std::string::npos) return text;
  const std::vector<std::string> node_keys(nodeKeys().begin(), nodeKeys().end());
  const std::string best = io::closestName(key, node_keys, 3);
  if (best.empty()) return text;
  const std::size_t hint = at + unknown.size();
  const std::string said = text.substr(hint);
  const std::string prefix = " (did you mean '";
  if (said.rfind(prefix, 0) == 0)
  {
    const std::string scene_best = said.substr(prefix.size(), said.find('\'', prefix.size()) - prefix.size());
    if (io::editDistance(key, scene_best) <= io::editDistance(key, best)) return text;
  }
  return text.substr(0, hint) + " (did you mean the node parameter '" + best + "'?)";
}

SceneConfig readScene(const NodeParameters& params)
{
  std::string yaml;
  try
  {
    yaml = sceneYaml(params.values, nodeKeys());
  }
  catch (const std::invalid_argument& e)
  {
    throw StartupError("parameter " + params.ns + "/" + e.what());
  }
  io::SceneLoadOptions load;
  load.packages = [](const std::string& pkg) { return ros::package::getPath(pkg); };
  std::string source = "private parameters of " + ros::this_node::getName();
  if (!params.scene_file.empty())
  {
    // Relative mesh, URDF and PLY names resolve against the scene file's folder, as for the runner.
    load.base_dir = std::filesystem::path(params.scene_file).parent_path().string();
    source = params.scene_file + " (~scene_file, with the " + source + ")";
  }
  SceneConfig scene;
  try
  {
    scene = io::parseScene(yaml, source, {}, load);
  }
  catch (const ConfigError& e)
  {
    throw StartupError("scene: " + sceneErrorText(e.what(), e.key()));
  }
  for (const std::string& w : scene.warnings) ROS_WARN("%s", withoutYamlLines(w).c_str());
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
    if (!opt.free_links.empty())
      throw StartupError("parameter " + pnh.getNamespace() + "/free_links: link '" + opt.free_links.front().link +
                         "' = " + opt.free_links.front().text +
                         ": robot_description_param is empty (no robot to take it from)");
    ROS_INFO("robot_description_param is empty: no robot links, only the scene's own bodies");
    return {};
  }
  // A relative name is searched for from the node's namespace upwards (as robot_description
  // usually is): the node in /fluid_sim finds /fluid_sim/robot_description, else
  // /robot_description. An absolute name is taken as it is.
  const std::string& key = opt.robot_description_param;
  std::string found;
  const bool absolute = key[0] == '/';
  if (absolute || !nh.searchParam(key, found)) found = nh.resolveName(key);
  std::string xml;
  if (!nh.getParam(found, xml))
  {
    const std::string top = "/" + key;  // the last place searched
    const std::string where = absolute || found == top ? "parameter '" + found + "' is not"
                                                       : "none of the parameters '" + found + "' ... '" + top + "' is";
    throw StartupError("missing robot_description: " + where +
                       " set (set it, e.g. with <param name=\"robot_description\" textfile=\"...\"/>, or "
                       "set ~robot_description_param to \"\" to run without a robot)");
  }
  const std::string source = "robot_description (" + found + ")";
  try
  {
    const io::UrdfRobot robot = io::parseUrdf(xml, source);
    if (opt.links_given_empty)
      ROS_WARN(
          "~links is an empty list: every link of %s with collision geometry is used, as without the "
          "parameter; to run without the robot, set ~robot_description_param to \"\"",
          source.c_str());
    io::UrdfBoundaryOptions u;
    u.links = opt.links;
    u.thin_links = opt.thin_links;
    u.spacing = scene.spacing;
    u.packages = [](const std::string& pkg) { return ros::package::getPath(pkg); };
    std::vector<std::string> warnings;
    std::vector<BoundaryConfig> links = io::urdfBoundaries(robot, u, &warnings);
    for (const std::string& w : warnings) ROS_WARN("%s", w.c_str());
    checkListedLinks(opt.container_links, links, pnh.getNamespace() + "/container_links");
    checkListedLinks(opt.thin_links, links, pnh.getNamespace() + "/thin_links");
    for (BoundaryConfig& b : links)
    {
      b.externally_posed = true;
      b.inside = std::find(opt.container_links.begin(), opt.container_links.end(), b.name) != opt.container_links.end();
      if (b.inside && b.type == ShapeType::Mesh && !b.mesh_closed)
        ROS_WARN(
            "parameter %s/container_links: link '%s' is an open mesh, which has no inside to keep water in: "
            "listing it does nothing (its walls hold water as any thin shell's do); close its mesh to make it "
            "a container",
            pnh.getNamespace().c_str(), b.name.c_str());
      for (const BoundaryConfig& s : scene.boundaries)
        if (s.name == b.name)
          throw StartupError("link '" + b.name + "' has the same name as a body of the scene; rename the scene body");
    }
    applyFreeLinks(opt.free_links, links, scene, pnh.getNamespace());
    return links;
  }
  catch (const ConfigError& e)
  {
    throw StartupError(e.what());
  }
}

}  // namespace ros_bridge
}  // namespace fluid_sim
