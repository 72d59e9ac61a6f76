// FluidSimNode wires the node's parts together (each in its own file pair):
//   node_parameters  the options, the scene and the robot links, read and validated once;
//   link_poses       tf lookup of the link poses;
//   solver_loop      the simulation, its thread, pacing and the commands it takes;
//   publishers       the topics and the publisher thread (messages.h: the converter);
//   services         reset / pause / step and dynamic_reconfigure;
//   master_watch     registers the node again with a restarted ROS master.
#include "fluid_sim/ros/fluid_sim_node.h"

#include <functional>
#include <map>
#include <mutex>
#include <string>

#include <ros/this_node.h>
#include <tbb/global_control.h>

#include "fluid_sim/ros/link_poses.h"
#include "fluid_sim/ros/master_watch.h"
#include "fluid_sim/ros/node_parameters.h"
#include "fluid_sim/ros/publishers.h"
#include "fluid_sim/ros/ros_names.h"
#include "fluid_sim/ros/services.h"
#include "fluid_sim/ros/solver_loop.h"

namespace fluid_sim
{
namespace ros_bridge
{
struct FluidSimNode::Impl
{
  ros::NodeHandle nh, pnh;
  NodeOptions opt;  // read once by start(), before any part uses it
  std::unique_ptr<tbb::global_control> threads;
  LinkPoses links{opt};
  Publishers publishers{opt};
  SolverLoop loop{opt, links, publishers};
  Services services{loop, publishers};
  MasterWatch master_watch{[this] {
    std::vector<std::string> names = services.names();
    // roscpp's own logger services, under the node's (or nodelet manager's) name.
    names.push_back(ros::this_node::getName() + "/get_loggers");
    names.push_back(ros::this_node::getName() + "/set_logger_level");
    return names;
  }};
  std::function<void(int)> on_finished;  // set before start()
  // Orders start()'s launch of the threads with stop(): once stop() has begun, none is launched.
  std::mutex lifecycle;
  bool stopped = false;  // under `lifecycle`

  Impl(ros::NodeHandle n, ros::NodeHandle p) : nh(n), pnh(p)
  {
    // A thread that died of an exception (already logged): the run ends with code 1.
    // The other thread is told to stop too (the nodelet then stays loaded, idle).
    loop.onFailure([this](const std::string&) {
      publishers.requestStop();
      master_watch.stop();
      if (on_finished) on_finished(1);
    });
    publishers.onFailure([this](const std::string&) {
      loop.requestStop();
      master_watch.stop();
      if (on_finished) on_finished(1);
    });
  }

  bool start()
  {
    const NodeParameters params = readNodeParameters(pnh);
    opt = readNodeOptions(params);
    publishers.setMaxPoints(static_cast<std::size_t>(opt.max_points));
    if (opt.threads > 0)
      threads = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                      static_cast<std::size_t>(opt.threads));
    SceneConfig scene = readScene(params);
    std::vector<BoundaryConfig> link_bodies = readRobotLinks(nh, pnh, opt, scene);
    loop.setScene(std::move(scene), std::move(link_bodies));
    links.listen(nh);
    // The watch runs from here on, not only once the threads start: a master restarted while the
    // node waits for tf would otherwise leave /tf's subscription unknown to the new master, and a
    // tf publisher started against it would never be announced to the node (which would wait on).
    // A start-up that fails or is stopped (no tf within tf_wait_timeout, a build error, stop())
    // stops it again.
    master_watch.start();
    struct StopWatchUnlessStarted
    {
      MasterWatch& watch;
      bool started = false;
      ~StopWatchUnlessStarted()
      {
        if (!started) watch.stop();
      }
    } watch_guard{master_watch};
    std::map<std::string, Pose> poses;
    ros::Time poses_stamp;
    if (!links.waitFor(loop.tfFrames(), loop.stopping(), poses, poses_stamp)) return false;
    loop.build(poses, poses_stamp);
    const Simulation& sim = loop.simulation();
    ROS_INFO(
        "fluid_sim: %zu fluid particles (%zu removed at start), %zu boundary particles in %zu bodies (%zu from "
        "tf), method %s, spacing %g m, fixed frame '%s', real_time_factor %g",
        sim.numFluidParticles(), sim.removedAtStart(), sim.boundaryPositions().size(), sim.numBodies(), links.size(),
        toString(sim.scene().solver.boundary_pressure), sim.scene().spacing, opt.fixed_frame.c_str(),
        opt.real_time_factor);

    // Before the threads: a name clash is a start-up error.
    const std::vector<BodyTopic> bodies = bodyTopics(sim, loop.freeLinkNames());
    for (const BodyTopic& b : bodies)
      if (b.free)
        ROS_INFO("free body '%s': frame '%s' on /tf, its state on %s", b.name.c_str(), b.frame.c_str(),
                 nh.resolveName("free_bodies").c_str());
    for (const BodyTopic& b : bodies)
      if (b.topic != "wrench/" + b.name)
        ROS_WARN("body '%s': its wrench is published on %s ('%s' is not a valid ROS name)", b.name.c_str(),
                 nh.resolveName(b.topic).c_str(), b.name.c_str());
    // The threads start only if stop() has not begun: a nodelet unloaded while start() was
    // still building must not get threads launched after its stop() returned.
    std::lock_guard<std::mutex> lock(lifecycle);
    if (stopped) return false;
    publishers.advertise(nh, bodies, sim);
    services.advertise(nh, pnh, opt);
    publishers.start();
    loop.start();
    watch_guard.started = true;
    return true;
  }

  void stop()
  {
    loop.requestStop();  // also ends a start() waiting for tf
    std::lock_guard<std::mutex> lock(lifecycle);
    if (stopped) return;
    stopped = true;
    master_watch.stop();
    publishers.requestStop();
    loop.join();
    publishers.join();
    services.shutdown();
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
  impl_->on_finished = callback;
  // The run is over: the master watch stops before the callback starts ROS's shutdown (which
  // unregisters the node, something the watch must not take for a master restart).
  impl_->loop.onFinished([this, callback = std::move(callback)](int code) {
    impl_->master_watch.stop();
    callback(code);
  });
}

}  // namespace ros_bridge
}  // namespace fluid_sim
