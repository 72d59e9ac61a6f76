#include "fluid_sim/ros/fluid_sim_node.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>
#include <thread>
#include <vector>

#include <dynamic_reconfigure/server.h>
#include <geometry_msgs/WrenchStamped.h>
#include <ros/package.h>
#include <std_srvs/SetBool.h>
#include <std_srvs/Trigger.h>
#include <tbb/global_control.h>
#include <tf2/exceptions.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include "fluid_msgs/ContactWrenchArray.h"
#include "fluid_msgs/SolverStats.h"
#include "fluid_msgs/StepSimulation.h"
#include "fluid_sim/FluidSimConfig.h"
#include "fluid_sim/core/simulation.h"
#include "fluid_sim/io/scene_loader.h"
#include "fluid_sim/io/urdf_loader.h"
#include "fluid_sim/ros/messages.h"
#include "fluid_sim/ros/param_yaml.h"

namespace fluid_sim
{
namespace ros_bridge
{
namespace
{
using WallClock = std::chrono::steady_clock;

double msSince(WallClock::time_point t0)
{
  return std::chrono::duration<double, std::milli>(WallClock::now() - t0).count();
}

/// The node's own private parameters; every other private parameter is a scene key.
struct NodeOptions
{
  std::string robot_description_param = "robot_description";  // "" = no robot
  std::string fixed_frame = "world";
  std::vector<std::string> links;            // empty = every link with collision geometry
  std::vector<std::string> container_links;  // links that hold water (inside: true)
  double real_time_factor = 1.0;             // 1 = tf-coupled; 0 = as fast as it can
  double publish_rate = 30.0;                // Hz
  int max_points = 0;                        // particles cloud size limit; 0 = all
  double tf_delay = 0.1;                     // s the simulated instant trails ROS time (rtf 1)
  double tf_wait_timeout = 0.0;              // s to wait for link tf at start; 0 = for ever
  double stop_after = 0.0;                   // s of simulated time, then finish; 0 = never
  int threads = 0;                           // solver threads; 0 = all cores
  bool publish_boundary = true;
};

/// Private parameters that are not scene keys: the node's options, and the values the
/// dynamic_reconfigure server writes back into the private namespace.
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

Pose toPose(const geometry_msgs::Transform& t)
{
  Pose p;
  p.translation = Vec3d(t.translation.x, t.translation.y, t.translation.z);
  p.rotation = Eigen::Quaterniond(t.rotation.w, t.rotation.x, t.rotation.y, t.rotation.z).normalized();
  return p;
}

bool samePose(const Pose& a, const Pose& b)
{
  return a.translation == b.translation && a.rotation.coeffs() == b.rotation.coeffs();
}

const char* viscosityName(ViscosityModel m)
{
  return toString(m);
}

ViscosityModel parseViscosity(const std::string& name)
{
  if (name == "artificial") return ViscosityModel::Artificial;
  if (name == "xsph") return ViscosityModel::Xsph;
  return ViscosityModel::None;
}

/// One body the node poses from tf.
struct LinkBody
{
  std::string link;
  std::size_t index = 0;  // in the simulation
  Pose last_pose;
  bool has_pose = false;
};

/// What the publisher thread turns into messages (copied out by the solver between steps).
struct Frame
{
  ros::Time stamp;
  FluidSnapshot fluid;
  bool boundary_valid = false;
  std::vector<Vec3> boundary;
  std::vector<Real> boundary_pressure;
  std::vector<std::pair<std::size_t, std::size_t>> body_ranges;  // (first, count) per body
  fluid_msgs::ContactWrenchArray wrenches;
  fluid_msgs::SolverStats stats;
};
}  // namespace

struct FluidSimNode::Impl
{
  ros::NodeHandle nh, pnh;
  NodeOptions opt;
  std::unique_ptr<tbb::global_control> threads;

  // Scene and simulation. `base_scene` has the scene's own bodies; link bodies are appended
  // with the poses tf gives at (re)start.
  SceneConfig base_scene;
  std::vector<BoundaryConfig> link_configs;  // shapes in link frames, from the URDF
  std::unique_ptr<Simulation> sim;
  std::vector<LinkBody> links;

  tf2_ros::Buffer tf_buffer{ros::Duration(60.0)};
  std::unique_ptr<tf2_ros::TransformListener> tf_listener;

  ros::Publisher pub_particles, pub_boundary, pub_wrenches, pub_stats;
  std::vector<ros::Publisher> pub_link_wrench;  // per body, wrench/<name>
  ros::ServiceServer srv_reset, srv_pause, srv_step;
  std::unique_ptr<dynamic_reconfigure::Server<fluid_sim::FluidSimConfig>> reconfigure;
  boost::recursive_mutex reconfigure_mutex;

  // Commands from service and reconfigure callbacks, applied by the solver thread between steps.
  std::mutex cmd_mutex;
  std::condition_variable cmd_cv;
  bool paused = false;
  bool reset_requested = false;
  bool reset_done = false;
  std::string reset_error;
  unsigned steps_requested = 0;
  std::uint64_t steps_done_counter = 0;
  std::optional<fluid_sim::FluidSimConfig> pending_config;
  bool reanchor = true;  // pacing restarts from the current instants (start, resume, reset, rtf change)

  // Live node settings (reconfigurable).
  std::atomic<double> publish_rate{30.0};
  std::atomic<double> real_time_factor{1.0};
  std::atomic<std::size_t> max_points{0};

  // Threads.
  std::atomic<bool> stopping{false};
  std::thread solver_thread, publisher_thread;
  std::function<void(int)> on_finished;

  // Solver-thread state.
  ros::Time anchor_ros;  // ROS time of simulated time anchor_sim (tf-coupled mode)
  double anchor_sim = 0.0;
  bool boundary_dirty = true;  // the boundary cloud must be (re)published
  double next_publish_sim = 0.0;
  WallClock::time_point next_publish_wall = WallClock::now();
  std::vector<Vec3d> force_sum, torque_sum;  // time-weighted, body frame, since the last publish
  std::vector<double> max_p;
  double weight_time = 0.0;
  StepReport last_report;
  std::string last_status = "ok";
  // Real-time factor over about a second of wall time.
  WallClock::time_point rtf_wall0 = WallClock::now();
  double rtf_sim0 = 0.0;
  double rtf_measured = 0.0;
  // Run statistics (for the summary printed at the end).
  std::uint64_t steps = 0, frames = 0;
  double sum_div_it = 0, sum_den_it = 0, sum_step_ms = 0, sum_copy_ms = 0;
  WallClock::time_point run_start = WallClock::now();

  // Frames: the solver fills `back`, swaps it with `pending`; the publisher swaps `pending` with
  // `front` and publishes from it. A slow publisher drops frames; it never blocks the solver.
  std::mutex frame_mutex;
  std::condition_variable frame_cv;
  Frame back, pending, front;
  std::vector<std::pair<std::size_t, std::size_t>> body_ranges;  // boundary particles of each body
  bool frame_ready = false;

  Impl(ros::NodeHandle n, ros::NodeHandle p) : nh(n), pnh(p) {}

  // ------------------------------------------------------------------------------ parameters
  template <typename T>
  void param(const std::string& name, T& value)
  {
    pnh.param(name, value, value);
  }

  void readOptions()
  {
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
    publish_rate = opt.publish_rate;
    real_time_factor = opt.real_time_factor;
    max_points = static_cast<std::size_t>(opt.max_points);
  }

  void loadScene()
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
    try
    {
      base_scene = io::parseScene(yaml, source, {}, load);
    }
    catch (const ConfigError& e)
    {
      throw StartupError(std::string("scene: ") + e.what());
    }
    for (const std::string& w : base_scene.warnings) ROS_WARN("%s", w.c_str());
  }

  void loadRobot()
  {
    if (opt.robot_description_param.empty())
    {
      if (!opt.links.empty())
        throw StartupError("parameter " + pnh.getNamespace() +
                           "/links is set but robot_description_param is empty (no robot to take them from)");
      ROS_INFO("robot_description_param is empty: no robot links, only the scene's own bodies");
      return;
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
      u.spacing = base_scene.spacing;
      u.packages = [](const std::string& pkg) { return ros::package::getPath(pkg); };
      std::vector<std::string> warnings;
      link_configs = io::urdfBoundaries(robot, u, &warnings);
      for (const std::string& w : warnings) ROS_WARN("%s", w.c_str());
      std::set<std::string> names;
      for (const BoundaryConfig& b : link_configs) names.insert(b.name);
      for (const std::string& c : opt.container_links)
      {
        if (!names.count(c))
          throw StartupError("parameter " + pnh.getNamespace() + "/container_links: link '" + c +
                             "' is not among the links used (" + std::to_string(names.size()) +
                             " links with collision geometry)");
      }
      for (BoundaryConfig& b : link_configs)
      {
        b.externally_posed = true;
        b.inside =
            std::find(opt.container_links.begin(), opt.container_links.end(), b.name) != opt.container_links.end();
        for (const BoundaryConfig& s : base_scene.boundaries)
          if (s.name == b.name)
            throw StartupError("link '" + b.name + "' has the same name as a body of the scene; rename the scene body");
      }
    }
    catch (const ConfigError& e)
    {
      throw StartupError(e.what());
    }
  }

  // ------------------------------------------------------------------------------ tf
  /// Pose of `link` in the fixed frame at `stamp` (ros::Time(0): the newest); nullopt if tf
  /// cannot give it, with the reason in `why`.
  std::optional<Pose> lookup(const std::string& link, const ros::Time& stamp, std::string* why)
  {
    try
    {
      return toPose(tf_buffer.lookupTransform(opt.fixed_frame, link, stamp).transform);
    }
    catch (const tf2::TransformException& e)
    {
      if (why) *why = e.what();
      return std::nullopt;
    }
  }

  /// Waits until tf knows every link in the fixed frame; returns their poses. False if ROS shut
  /// down or stop() was called meanwhile.
  bool waitForLinks(std::map<std::string, Pose>& poses)
  {
    const ros::WallTime start = ros::WallTime::now();
    ros::WallTime last_note = start;
    bool noted = false;
    while (ros::ok() && !stopping)
    {
      std::vector<std::string> missing;
      std::string why;
      for (const BoundaryConfig& b : link_configs)
      {
        if (poses.count(b.name)) continue;
        if (auto p = lookup(b.name, ros::Time(0), &why))
          poses[b.name] = *p;
        else
          missing.push_back(b.name);
      }
      if (missing.empty())
      {
        if (noted) ROS_INFO("tf now has every link; starting");
        return true;
      }
      const double waited = (ros::WallTime::now() - start).toSec();
      std::ostringstream list;
      for (std::size_t k = 0; k < missing.size(); ++k) list << (k ? ", " : "") << missing[k];
      if (opt.tf_wait_timeout > 0.0 && waited > opt.tf_wait_timeout)
        throw StartupError("tf: no transform from '" + opt.fixed_frame + "' to link(s) " + list.str() + " after " +
                           std::to_string(opt.tf_wait_timeout) + " s (~tf_wait_timeout); last error: " + why);
      if (!noted || (ros::WallTime::now() - last_note).toSec() > 5.0)
      {
        ROS_WARN(
            "waiting for tf: no transform yet from fixed frame '%s' to link(s) %s (is robot_state_publisher "
            "running and the fixed frame connected to the robot?) [%s]",
            opt.fixed_frame.c_str(), list.str().c_str(), why.c_str());
        last_note = ros::WallTime::now();
        noted = true;
      }
      ros::WallDuration(0.05).sleep();
    }
    return false;
  }

  /// Builds the simulation with the link bodies at `poses`. Throws StartupError.
  void build(const std::map<std::string, Pose>& poses)
  {
    SceneConfig scene = base_scene;
    for (BoundaryConfig b : link_configs)
    {
      b.pose = poses.at(b.name);
      scene.boundaries.push_back(std::move(b));
    }
    try
    {
      auto next = std::make_unique<Simulation>(scene);
      sim = std::move(next);
    }
    catch (const ConfigError& e)
    {
      throw StartupError(std::string("scene: ") + e.what());
    }
    links.clear();
    for (const BoundaryConfig& b : link_configs)
    {
      LinkBody lb;
      lb.link = b.name;
      lb.index = sim->bodyIndex(b.name);
      lb.last_pose = poses.at(b.name);
      lb.has_pose = true;
      links.push_back(lb);
    }
    const std::size_t nb = sim->numBodies();
    body_ranges.clear();
    for (std::size_t k = 0; k < nb; ++k)
    {
      const BodyInfo b = sim->body(k);
      body_ranges.emplace_back(b.first_particle, b.num_particles);
    }
    force_sum.assign(nb, Vec3d::Zero());
    torque_sum.assign(nb, Vec3d::Zero());
    max_p.assign(nb, 0.0);
    weight_time = 0.0;
    boundary_dirty = true;
    reanchor = true;
    rtf_sim0 = 0.0;
    rtf_wall0 = WallClock::now();
  }

  // ------------------------------------------------------------------------------ start
  bool start()
  {
    readOptions();
    if (opt.threads > 0)
      threads = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                      static_cast<std::size_t>(opt.threads));
    loadScene();
    loadRobot();
    tf_listener = std::make_unique<tf2_ros::TransformListener>(tf_buffer, nh);
    std::map<std::string, Pose> poses;
    if (!waitForLinks(poses)) return false;
    build(poses);
    ROS_INFO(
        "fluid_sim: %zu fluid particles (%zu removed at start), %zu boundary particles in %zu bodies (%zu from "
        "tf), method %s, spacing %g m, fixed frame '%s', real_time_factor %g",
        sim->numFluidParticles(), sim->removedAtStart(), sim->boundaryPositions().size(), sim->numBodies(),
        links.size(), toString(sim->scene().solver.boundary_pressure), sim->scene().spacing, opt.fixed_frame.c_str(),
        opt.real_time_factor);

    pub_particles = pnh.advertise<sensor_msgs::PointCloud2>("particles", 2);
    pub_boundary = pnh.advertise<sensor_msgs::PointCloud2>("boundary_particles", 1, true);
    pub_wrenches = pnh.advertise<fluid_msgs::ContactWrenchArray>("contact_wrenches", 10);
    pub_stats = pnh.advertise<fluid_msgs::SolverStats>("stats", 10);
    for (std::size_t k = 0; k < sim->numBodies(); ++k)
      pub_link_wrench.push_back(pnh.advertise<geometry_msgs::WrenchStamped>("wrench/" + sim->body(k).name, 10));

    srv_reset = pnh.advertiseService("reset", &Impl::onReset, this);
    srv_pause = pnh.advertiseService("pause", &Impl::onPause, this);
    srv_step = pnh.advertiseService("step", &Impl::onStep, this);

    // dynamic_reconfigure, started from the scene's values (not the .cfg defaults).
    reconfigure = std::make_unique<dynamic_reconfigure::Server<fluid_sim::FluidSimConfig>>(reconfigure_mutex, pnh);
    fluid_sim::FluidSimConfig cfg;
    const SceneConfig& s = sim->scene();
    cfg.density_error = s.solver.density_error;
    cfg.divergence_error = s.solver.divergence_error;
    cfg.min_iterations = s.solver.min_iterations;
    cfg.max_iterations = s.solver.max_iterations;
    cfg.warm_start = s.solver.warm_start;
    cfg.viscosity_model = viscosityName(s.viscosity.model);
    cfg.viscosity_coefficient = s.viscosity.coefficient;
    cfg.boundary_viscosity = s.viscosity.boundary;
    cfg.publish_rate = opt.publish_rate;
    cfg.real_time_factor = opt.real_time_factor;
    cfg.max_points = opt.max_points;
    reconfigure->updateConfig(cfg);
    reconfigure->setCallback([this](fluid_sim::FluidSimConfig& c, uint32_t) { onReconfigure(c); });

    run_start = WallClock::now();
    publisher_thread = std::thread([this] { publisherLoop(); });
    solver_thread = std::thread([this] { solverLoop(); });
    return true;
  }

  // ------------------------------------------------------------------------------ callbacks
  void onReconfigure(const fluid_sim::FluidSimConfig& c)
  {
    publish_rate = c.publish_rate;
    max_points = static_cast<std::size_t>(std::max(0, c.max_points));
    std::lock_guard<std::mutex> lock(cmd_mutex);
    if (c.real_time_factor != real_time_factor.load())
    {
      real_time_factor = c.real_time_factor;
      reanchor = true;
    }
    pending_config = c;
  }

  bool onReset(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res)
  {
    std::unique_lock<std::mutex> lock(cmd_mutex);
    reset_requested = true;
    reset_done = false;
    cmd_cv.notify_all();
    cmd_cv.wait_for(lock, std::chrono::seconds(120), [&] { return reset_done || stopping.load(); });
    res.success = reset_done && reset_error.empty();
    res.message = !reset_done ? "reset timed out" : reset_error.empty() ? "reset to the initial scene" : reset_error;
    return true;
  }

  bool onPause(std_srvs::SetBool::Request& req, std_srvs::SetBool::Response& res)
  {
    std::lock_guard<std::mutex> lock(cmd_mutex);
    if (paused && !req.data) reanchor = true;  // resume: pacing restarts from now
    paused = req.data;
    cmd_cv.notify_all();
    res.success = true;
    res.message = paused ? "paused" : "running";
    return true;
  }

  bool onStep(fluid_msgs::StepSimulation::Request& req, fluid_msgs::StepSimulation::Response& res)
  {
    std::unique_lock<std::mutex> lock(cmd_mutex);
    if (!paused)
    {
      res.success = false;
      res.message = "the simulation is running: pause it first (service pause, data: true)";
      return true;
    }
    if (req.steps == 0)
    {
      res.success = false;
      res.message = "steps must be at least 1";
      return true;
    }
    const std::uint64_t target = steps_done_counter + steps_requested + req.steps;
    steps_requested += req.steps;
    cmd_cv.notify_all();
    const bool done = cmd_cv.wait_for(lock, std::chrono::seconds(300),
                                      [&] { return steps_done_counter >= target || stopping.load() || !paused; });
    res.success = done && steps_done_counter >= target;
    res.message = res.success ? last_status : "interrupted before all steps were taken";
    res.sim_time = sim ? sim->time() : 0.0;  // read under cmd_mutex: the solver holds it while stepping on request
    return true;
  }

  // ------------------------------------------------------------------------------ solver thread
  /// Applies commands; returns true if a step may be taken now. Called with cmd_mutex held.
  void applyCommands(std::unique_lock<std::mutex>& lock)
  {
    if (reset_requested)
    {
      reset_requested = false;
      reset_error.clear();
      std::map<std::string, Pose> poses;
      for (const LinkBody& lb : links)
      {
        std::string why;
        auto p = lookup(lb.link, ros::Time(0), &why);
        poses[lb.link] = p ? *p : lb.last_pose;
      }
      const SolverConfig solver = sim->scene().solver;
      const ViscosityConfig visc = sim->scene().viscosity;
      const StabilityConfig stab = sim->scene().stability;
      try
      {
        build(poses);
        sim->updateSettings(solver, visc, stab);  // live settings survive a reset
        steps = 0;
        last_status = "ok";
        ROS_INFO("reset: %zu fluid particles", sim->numFluidParticles());
      }
      catch (const std::exception& e)
      {
        reset_error = std::string("reset failed: ") + e.what();
        ROS_ERROR("%s", reset_error.c_str());
      }
      reset_done = true;
      cmd_cv.notify_all();
    }
    if (pending_config)
    {
      const fluid_sim::FluidSimConfig c = *pending_config;
      pending_config.reset();
      SolverConfig solver = sim->scene().solver;
      ViscosityConfig visc = sim->scene().viscosity;
      solver.density_error = c.density_error;
      solver.divergence_error = c.divergence_error;
      solver.min_iterations = c.min_iterations;
      solver.max_iterations = c.max_iterations;
      solver.warm_start = c.warm_start;
      visc.model = parseViscosity(c.viscosity_model);
      visc.coefficient = c.viscosity_coefficient;
      visc.boundary = c.boundary_viscosity;
      try
      {
        sim->updateSettings(solver, visc, sim->scene().stability);
        ROS_INFO(
            "settings: density_error %g, divergence_error %g, iterations %d..%d, warm_start %s, viscosity %s %g "
            "(walls %g), publish_rate %g Hz, real_time_factor %g, max_points %d",
            c.density_error, c.divergence_error, c.min_iterations, c.max_iterations, c.warm_start ? "on" : "off",
            c.viscosity_model.c_str(), c.viscosity_coefficient, c.boundary_viscosity, c.publish_rate,
            c.real_time_factor, c.max_points);
      }
      catch (const ConfigError& e)
      {
        ROS_ERROR("dynamic_reconfigure: refused, the solver keeps its settings: %s", e.what());
      }
    }
    (void)lock;
  }

  /// Poses every tf-driven body for the step starting now. `stamp`: ROS time of the simulated
  /// instant, or ros::Time(0) for the newest poses. `jump`: place without deriving velocities.
  void poseLinks(const ros::Time& stamp, bool jump)
  {
    for (LinkBody& lb : links)
    {
      std::string why;
      std::optional<Pose> p = lookup(lb.link, stamp, &why);
      if (!p && !stamp.isZero())
      {
        // tf has nothing at that instant (usually: nothing newer yet); take the newest.
        ROS_WARN_THROTTLE(5.0, "tf: no pose of '%s' at %.3f (%s); using the newest one", lb.link.c_str(), stamp.toSec(),
                          why.c_str());
        p = lookup(lb.link, ros::Time(0), &why);
      }
      if (!p)
      {
        ROS_WARN_THROTTLE(5.0, "tf: no pose of '%s' (%s); it stays where it was", lb.link.c_str(), why.c_str());
        continue;
      }
      if (lb.has_pose && samePose(*p, lb.last_pose) && !jump) continue;  // static: no rewrite
      sim->setBodyPose(lb.index, *p, jump);
      lb.last_pose = *p;
      lb.has_pose = true;
    }
  }

  void solverLoop()
  {
    bool finished = false;
    while (!stopping)
    {
      bool stepping_on_request = false;
      bool jump = false;
      double rtf = 0.0;
      {
        std::unique_lock<std::mutex> lock(cmd_mutex);
        applyCommands(lock);
        if ((paused || finished) && steps_requested == 0)
        {
          lock.unlock();
          publishPausedStats();
          std::unique_lock<std::mutex> relock(cmd_mutex);
          cmd_cv.wait_for(relock, std::chrono::milliseconds(200));
          continue;
        }
        stepping_on_request = paused && steps_requested > 0;
        rtf = real_time_factor;
        if (reanchor && !stepping_on_request && rtf > 0.0 && ros::Time::now().isZero())
        {
          // use_sim_time and no /clock yet: ROS time is 0 until the first message.
          lock.unlock();
          ROS_INFO_THROTTLE(5.0, "waiting for /clock (use_sim_time is set)");
          std::this_thread::sleep_for(std::chrono::milliseconds(10));
          continue;
        }
        if (reanchor && !stepping_on_request)
        {
          anchor_sim = sim->time();
          // Simulated time anchor_sim is ROS time now; steps then trail ROS time by tf_delay (see
          // the pacing below), so tf holds poses on both sides of every instant looked up. An
          // anchor before now could ask for poses older than tf has (a jump back and forth).
          anchor_ros = ros::Time::now();
          reanchor = false;
          jump = true;
          next_publish_sim = sim->time();
          rtf_sim0 = sim->time();
          rtf_wall0 = WallClock::now();
        }
      }

      const double t = sim->time();
      const double dt = sim->nextTimeStep();
      const bool coupled = rtf == 1.0 && !stepping_on_request;
      if (rtf > 0.0 && !stepping_on_request)
      {
        // Pace: the step from t to t + dt may run once ROS time has passed t + dt (scaled), plus the
        // tf delay in coupled mode so that tf already holds the poses at t.
        const ros::Time due =
            anchor_ros + ros::Duration((t + dt - anchor_sim) / rtf) + ros::Duration(coupled ? opt.tf_delay : 0.0);
        while (!stopping && ros::ok())
        {
          const ros::Time now = ros::Time::now();
          if (now >= due) break;
          if (now < anchor_ros)
          {
            // ROS time went back (a bag or a simulator restarted under use_sim_time).
            ROS_WARN("ROS time jumped back from %.3f to %.3f s; simulated time continues from there",
                     anchor_ros.toSec(), now.toSec());
            std::lock_guard<std::mutex> lock(cmd_mutex);
            reanchor = true;
            break;
          }
          {
            std::lock_guard<std::mutex> lock(cmd_mutex);
            if (reset_requested || paused || reanchor) break;
          }
          const double wait = std::min((due - now).toSec(), 0.005);
          std::this_thread::sleep_for(std::chrono::duration<double>(std::max(wait, 1e-4)));
        }
        std::lock_guard<std::mutex> lock(cmd_mutex);
        if (reset_requested || paused || reanchor) continue;
        const double lag = (ros::Time::now() - due).toSec();
        if (lag > 0.5)
          ROS_WARN_THROTTLE(10.0,
                            "cannot keep up with real_time_factor %g: %.2f s behind ROS time (achieving %.2f); "
                            "lower real_time_factor, coarsen the spacing, or give it more cores",
                            rtf, lag, rtf_measured);
      }

      const ros::Time pose_stamp = coupled ? anchor_ros + ros::Duration(t - anchor_sim) : ros::Time(0);
      if (stopping) break;

      std::unique_lock<std::mutex> step_lock(cmd_mutex, std::defer_lock);
      if (stepping_on_request) step_lock.lock();  // a step service call reads sim_time under it
      poseLinks(pose_stamp, jump);
      const StepReport rep = sim->step();
      afterStep(rep, coupled);
      if (stepping_on_request)
      {
        --steps_requested;
        ++steps_done_counter;
        cmd_cv.notify_all();
        step_lock.unlock();
      }

      if (rep.unstable)
      {
        last_status = "unstable: " + rep.reason;
        ROS_ERROR("simulation unstable at t = %.4f s: %s. Paused; call ~reset to start again.", rep.time,
                  rep.reason.c_str());
        publishFrame(rep, coupled, true);
        std::lock_guard<std::mutex> lock(cmd_mutex);
        paused = true;
        steps_requested = 0;
        cmd_cv.notify_all();
        if (opt.stop_after > 0.0)
        {
          finished = true;
          printSummary();
          if (on_finished) on_finished(3);
        }
        continue;
      }
      if (opt.stop_after > 0.0 && !finished && sim->time() >= opt.stop_after - 1e-9)
      {
        publishFrame(rep, coupled, true);
        finished = true;
        printSummary();
        if (on_finished) on_finished(0);
      }
    }
  }

  void afterStep(const StepReport& rep, bool coupled)
  {
    ++steps;
    sum_div_it += rep.divergence_iterations;
    sum_den_it += rep.density_iterations;
    sum_step_ms += rep.ms_total;
    last_report = rep;
    last_status = rep.unstable                                            ? "unstable: " + rep.reason
                  : (!rep.density_converged || !rep.divergence_converged) ? "not_converged"
                                                                          : "ok";
    for (std::size_t k = 0; k < sim->numBodies(); ++k)
    {
      const BodyInfo b = sim->body(k);
      force_sum[k] += rep.dt * b.force_body;
      torque_sum[k] += rep.dt * b.torque_body;
      max_p[k] = std::max(max_p[k], b.max_pressure);
    }
    weight_time += rep.dt;

    const double wall = std::chrono::duration<double>(WallClock::now() - rtf_wall0).count();
    if (wall >= 1.0)
    {
      rtf_measured = (sim->time() - rtf_sim0) / wall;
      rtf_sim0 = sim->time();
      rtf_wall0 = WallClock::now();
    }
    else if (rtf_measured == 0.0 && wall > 0.0)
    {
      rtf_measured = (sim->time() - rtf_sim0) / wall;
    }

    const double rate = publish_rate;
    bool due;
    if (coupled)
    {
      due = sim->time() >= next_publish_sim - 1e-12;
      if (due) next_publish_sim = std::max(next_publish_sim + 1.0 / rate, sim->time());
    }
    else
    {
      due = WallClock::now() >= next_publish_wall;
      if (due)
        next_publish_wall = WallClock::now() +
                            std::chrono::duration_cast<WallClock::duration>(std::chrono::duration<double>(1.0 / rate));
    }
    if (due) publishFrame(rep, coupled, false);
  }

  fluid_msgs::SolverStats makeStats(const StepReport& rep, bool is_paused) const
  {
    fluid_msgs::SolverStats s;
    s.sim_time = sim->time();
    s.time_step = rep.dt;
    s.divergence_iterations = rep.divergence_iterations;
    s.density_iterations = rep.density_iterations;
    s.density_error = rep.density_error;
    s.divergence_error = rep.divergence_error;
    s.max_speed = rep.max_speed;
    s.fluid_particles = static_cast<std::uint32_t>(sim->numFluidParticles());
    s.removed_particles = static_cast<std::uint32_t>(sim->removedTotal());
    s.step_wall_time = rep.ms_total * 1e-3;
    s.real_time_factor = rtf_measured;
    s.paused = is_paused;
    s.status = last_status;
    return s;
  }

  /// Copies the state into `back` and hands it to the publisher thread.
  void publishFrame(const StepReport& rep, bool coupled, bool force)
  {
    (void)force;
    const auto t0 = WallClock::now();
    Frame& f = back;
    f.stamp = coupled ? anchor_ros + ros::Duration(sim->time() - anchor_sim) : ros::Time::now();
    f.fluid.positions = sim->positions();
    f.fluid.velocities = sim->velocities();
    f.fluid.pressures = sim->pressures();
    f.fluid.densities = sim->densities();
    bool any_moving = false;
    for (std::size_t k = 0; k < sim->numBodies() && !any_moving; ++k) any_moving = sim->body(k).moving;
    f.boundary_valid = opt.publish_boundary && (boundary_dirty || any_moving);
    if (f.boundary_valid)
    {
      f.boundary = sim->boundaryPositions();
      f.boundary_pressure = sim->boundaryPressures();
      f.body_ranges = body_ranges;
      boundary_dirty = false;
    }
    f.wrenches.header.stamp = f.stamp;
    f.wrenches.header.frame_id = opt.fixed_frame;
    f.wrenches.wrenches.resize(sim->numBodies());
    const double w = weight_time > 0.0 ? 1.0 / weight_time : 0.0;
    for (std::size_t k = 0; k < sim->numBodies(); ++k)
    {
      const BodyInfo b = sim->body(k);
      fluid_msgs::ContactWrench& cw = f.wrenches.wrenches[k];
      cw.link = b.name;
      // Mean over the steps since the last publication (pressure forces jitter step to step).
      cw.wrench =
          weight_time > 0.0 ? toWrench(w * force_sum[k], w * torque_sum[k]) : toWrench(b.force_body, b.torque_body);
      cw.contact_particles = static_cast<std::uint32_t>(b.contact_particles);
      cw.max_pressure = max_p[k];
      force_sum[k].setZero();
      torque_sum[k].setZero();
      max_p[k] = 0.0;
    }
    weight_time = 0.0;
    f.stats = makeStats(rep, paused);
    f.stats.header.stamp = f.stamp;
    f.stats.header.frame_id = opt.fixed_frame;
    sum_copy_ms += msSince(t0);
    ++frames;
    {
      std::lock_guard<std::mutex> lock(frame_mutex);
      std::swap(back, pending);
      // A frame the publisher has not taken yet is replaced; keep its boundary cloud if the new
      // one has none (it must not be lost: it is latched and published only when it changes).
      if (!pending.boundary_valid && back.boundary_valid)
      {
        std::swap(pending.boundary, back.boundary);
        std::swap(pending.boundary_pressure, back.boundary_pressure);
        std::swap(pending.body_ranges, back.body_ranges);
        pending.boundary_valid = true;
      }
      back.boundary_valid = false;
      frame_ready = true;
    }
    frame_cv.notify_one();
  }

  void publishPausedStats()
  {
    static thread_local WallClock::time_point last;
    if (WallClock::now() - last < std::chrono::seconds(1)) return;
    last = WallClock::now();
    fluid_msgs::SolverStats s = makeStats(last_report, true);
    s.header.stamp = ros::Time::now();
    s.header.frame_id = opt.fixed_frame;
    pub_stats.publish(s);
  }

  // ------------------------------------------------------------------------------ publisher thread
  void publisherLoop()
  {
    while (true)
    {
      {
        std::unique_lock<std::mutex> lock(frame_mutex);
        frame_cv.wait(lock, [&] { return frame_ready || stopping.load(); });
        if (!frame_ready && stopping) return;
        std::swap(front, pending);
        pending.boundary_valid = false;
        frame_ready = false;
      }
      const Frame& f = front;
      if (pub_particles.getNumSubscribers() > 0)
      {
        // A new message each time: nodelet subscribers may keep the previous one (zero copy).
        boost::shared_ptr<sensor_msgs::PointCloud2> cloud(new sensor_msgs::PointCloud2);
        cloud->header.stamp = f.stamp;
        cloud->header.frame_id = opt.fixed_frame;
        fillParticleCloud(f.fluid, max_points, *cloud);
        pub_particles.publish(cloud);
      }
      if (f.boundary_valid)
      {
        boost::shared_ptr<sensor_msgs::PointCloud2> cloud(new sensor_msgs::PointCloud2);
        cloud->header.stamp = f.stamp;
        cloud->header.frame_id = opt.fixed_frame;
        fillBoundaryCloud(f.boundary, f.boundary_pressure, f.body_ranges, *cloud);
        pub_boundary.publish(cloud);
      }
      pub_wrenches.publish(f.wrenches);
      for (std::size_t k = 0; k < f.wrenches.wrenches.size() && k < pub_link_wrench.size(); ++k)
      {
        geometry_msgs::WrenchStamped ws;
        ws.header.stamp = f.stamp;
        ws.header.frame_id = f.wrenches.wrenches[k].link;
        ws.wrench = f.wrenches.wrenches[k].wrench;
        pub_link_wrench[k].publish(ws);
      }
      pub_stats.publish(f.stats);
    }
  }

  void printSummary()
  {
    const double wall = std::chrono::duration<double>(WallClock::now() - run_start).count();
    const double n = steps > 0 ? double(steps) : 1.0;
    std::ostringstream os;
    os << "fluid_sim: finished at t = " << sim->time() << " s after " << steps << " steps in " << wall
       << " s wall (real-time factor " << (wall > 0 ? sim->time() / wall : 0.0) << ")\n"
       << "  status " << last_status << "; fluid particles " << sim->numFluidParticles() << ", removed "
       << sim->removedTotal() << "\n"
       << "  per step: " << sum_step_ms / n << " ms, divergence iterations " << sum_div_it / n
       << ", density iterations " << sum_den_it / n << "; last density error " << last_report.density_error << "\n"
       << "  publishing: " << frames << " frames, copying a frame out of the solver took "
       << (frames ? sum_copy_ms / double(frames) : 0.0) << " ms ("
       << (frames ? 100.0 * (sum_copy_ms / frames) / (sum_step_ms / n) : 0.0) << " % of a step)\n";
    for (std::size_t k = 0; k < sim->numBodies(); ++k)
    {
      const BodyInfo b = sim->body(k);
      os << "  " << b.name << ": force [" << b.force_body.x() << ", " << b.force_body.y() << ", " << b.force_body.z()
         << "] N, torque [" << b.torque_body.x() << ", " << b.torque_body.y() << ", " << b.torque_body.z()
         << "] N m (link frame), " << b.contact_particles << " contact particles\n";
    }
    std::fputs(os.str().c_str(), stdout);
    std::fflush(stdout);
  }

  void stop()
  {
    {
      std::lock_guard<std::mutex> lock(cmd_mutex);
      if (stopping.exchange(true)) return;
      cmd_cv.notify_all();
    }
    frame_cv.notify_all();
    if (solver_thread.joinable()) solver_thread.join();
    {
      std::lock_guard<std::mutex> lock(frame_mutex);
    }
    frame_cv.notify_all();
    if (publisher_thread.joinable()) publisher_thread.join();
    srv_reset.shutdown();
    srv_pause.shutdown();
    srv_step.shutdown();
  }
};

FluidSimNode::FluidSimNode(ros::NodeHandle nh, ros::NodeHandle pnh) : impl_(std::make_unique<Impl>(nh, pnh)) {}

FluidSimNode::~FluidSimNode()
{
  stop();
}

bool FluidSimNode::start()
{
  return impl_->start();
}

void FluidSimNode::stop()
{
  impl_->stop();
}

void FluidSimNode::onFinished(std::function<void(int)> callback)
{
  impl_->on_finished = std::move(callback);
}

}  // namespace ros_bridge
}  // namespace fluid_sim
