#pragma once
// Watches the ROS master and re-registers the node with a master that has forgotten it.
//
// roscpp registers topics, subscriptions and services once, when they are created. A master
// that is restarted (roscore killed and started again) knows none of them: connections that
// already exist keep flowing (they are peer to peer), but no new subscriber finds the node's
// topics, no service call finds its services and `rosnode list` does not show it. This watch
// asks the master once a second whether it knows this node (lookupNode); when a master answers
// that it does not, everything the process offers is registered again through the master's
// public XML-RPC API: the publications and subscriptions the process's own slave API lists
// (getPublications, getSubscriptions), and the services the node names. Publishers already
// registered with the new master are handed to the subscriptions (publisherUpdate), as roscpp
// does when a subscription is created, together with the publishers each subscription is linked
// to now (getBusInfo): roscpp drops the links a publisherUpdate leaves out, and publishers that
// do not register again (roscpp and rospy nodes do not) would otherwise be cut off. The new
// master's own updates (when another publisher of the topic registers) leave them out too: each
// check puts such a link back, once (a publisher that does not link again has gone away).

#include <condition_variable>
#include <functional>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

namespace fluid_sim
{
namespace ros_bridge
{
class MasterWatch
{
public:
  /// `services`: the fully resolved names of the services to register again (those the process
  /// no longer serves are skipped). `period`: seconds between two checks.
  explicit MasterWatch(std::function<std::vector<std::string>()> services, double period = 1.0);
  ~MasterWatch();
  MasterWatch(const MasterWatch&) = delete;
  MasterWatch& operator=(const MasterWatch&) = delete;

  /// Starts the watch thread (once).
  void start();
  /// Stops and joins it; idempotent, and safe to call from several threads at once.
  void stop();

  /// One check: is the master reachable, and does it know this node? If it is reachable and does
  /// not, registers everything again. Returns true if the node is (now) registered. Logs a
  /// warning when the master becomes unreachable and an info line when it is back.
  bool checkOnce();

  /// How many times the node was registered again since start (for tests and the stats log).
  int reRegistrations() const;

private:
  void run();
  /// Registers publications, subscriptions and services with the master; false if any call
  /// failed (then the next check tries again).
  bool registerAll();
  /// Puts back the links to publishers the master does not know that registerAll() kept and a
  /// master's publisherUpdate has dropped since.
  void keepLinks();

  std::function<std::vector<std::string>()> services_;
  double period_;  // s
  std::thread thread_;
  mutable std::mutex mutex_;
  std::mutex join_mutex_;  // one stop() at a time joins thread_
  std::condition_variable wake_;
  bool stopping_ = false;         // under mutex_
  bool master_reachable_ = true;  // only the checking thread touches it
  int re_registrations_ = 0;      // under mutex_
  // Only the checking thread touches these. By subscribed topic: the publishers linked at the
  // last re-registration that the master did not know, and those of them put back once.
  std::map<std::string, std::set<std::string>> kept_;
  std::map<std::string, std::set<std::string>> retried_;
};

}  // namespace ros_bridge
}  // namespace fluid_sim
