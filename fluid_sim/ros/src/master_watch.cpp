#include "fluid_sim/ros/master_watch.h"

#include <chrono>
#include <map>
#include <set>

#include <ros/connection_manager.h>
#include <ros/console.h>
#include <ros/init.h>
#include <ros/master.h>
#include <ros/network.h>
#include <ros/service_manager.h>
#include <ros/this_node.h>
#include <ros/xmlrpc_manager.h>

namespace fluid_sim
{
namespace ros_bridge
{
namespace
{
/// One call of the process's own slave API (getPublications, getSubscriptions, publisherUpdate);
/// false if it did not answer with code 1.
bool callSelf(const std::string& method, const XmlRpc::XmlRpcValue& params, XmlRpc::XmlRpcValue& payload)
{
  std::string host;
  uint32_t port = 0;
  if (!ros::network::splitURI(ros::XMLRPCManager::instance()->getServerURI(), host, port)) return false;
  XmlRpc::XmlRpcClient* client = ros::XMLRPCManager::instance()->getXMLRPCClient(host, port, "/");
  XmlRpc::XmlRpcValue result;
  // Blocking: a non-blocking call would need the client's socket on a dispatcher that runs, which
  // roscpp keeps private. checkOnce() never calls this once ROS is shutting down.
  const bool done = client->execute(method.c_str(), params, result);
  const bool ok = done && ros::XMLRPCManager::instance()->validateXmlrpcResponse(method, result, payload);
  ros::XMLRPCManager::instance()->releaseXMLRPCClient(client);
  return ok;
}

/// [[topic, type], ...] from getPublications / getSubscriptions.
std::vector<std::pair<std::string, std::string>> topicList(const std::string& method)
{
  XmlRpc::XmlRpcValue params, payload;
  params[0] = ros::this_node::getName();
  std::vector<std::pair<std::string, std::string>> topics;
  if (!callSelf(method, params, payload) || payload.getType() != XmlRpc::XmlRpcValue::TypeArray) return topics;
  for (int k = 0; k < payload.size(); ++k)
    if (payload[k].getType() == XmlRpc::XmlRpcValue::TypeArray && payload[k].size() == 2)
      topics.emplace_back(std::string(payload[k][0]), std::string(payload[k][1]));
  return topics;
}

/// The XML-RPC URIs of the publishers each subscription of this process is linked to now, by
/// topic: the inbound ("i") connections of the process's getBusInfo, whose destination is the
/// publisher's slave API (what the master's publisher lists hold). Only links roscpp still holds
/// are listed: one it has dropped (its publisher unregistered, or refused a reconnection) is not.
std::map<std::string, std::set<std::string>> connectedPublishers()
{
  XmlRpc::XmlRpcValue params, payload;
  params[0] = ros::this_node::getName();
  std::map<std::string, std::set<std::string>> publishers;
  if (!callSelf("getBusInfo", params, payload) || payload.getType() != XmlRpc::XmlRpcValue::TypeArray)
    return publishers;
  // Each connection: [id, destination, direction, transport, topic, connected, info].
  for (int k = 0; k < payload.size(); ++k)
  {
    XmlRpc::XmlRpcValue& c = payload[k];
    if (c.getType() != XmlRpc::XmlRpcValue::TypeArray || c.size() < 5) continue;
    if (c[1].getType() != XmlRpc::XmlRpcValue::TypeString || c[2].getType() != XmlRpc::XmlRpcValue::TypeString ||
        c[4].getType() != XmlRpc::XmlRpcValue::TypeString)
      continue;
    if (std::string(c[2]) == "i") publishers[std::string(c[4])].insert(std::string(c[1]));
  }
  return publishers;
}

/// registerSubscriber / registerPublisher / registerService with the master: each takes
/// (caller_id, name, type or service URI, caller_api). registerSubscriber's payload is the list
/// of the topic's publishers the master knows; registering again is harmless.
bool registerWithMaster(const char* method, const std::string& name, const std::string& arg,
                        XmlRpc::XmlRpcValue& payload)
{
  XmlRpc::XmlRpcValue params, result;
  params[0] = ros::this_node::getName();
  params[1] = name;
  params[2] = arg;
  params[3] = ros::XMLRPCManager::instance()->getServerURI();
  return ros::master::execute(method, params, result, payload, false);
}

std::set<std::string> uriSet(XmlRpc::XmlRpcValue& list)
{
  std::set<std::string> uris;
  if (list.getType() == XmlRpc::XmlRpcValue::TypeArray)
    for (int k = 0; k < list.size(); ++k)
      if (list[k].getType() == XmlRpc::XmlRpcValue::TypeString) uris.insert(std::string(list[k]));
  return uris;
}

/// Hands `topic`'s subscription the publishers `listed` and `extra` (roscpp connects to those it
/// has no link to and drops the links to every other one).
void updatePublishers(const std::string& topic, const std::set<std::string>& listed, const std::set<std::string>& extra)
{
  XmlRpc::XmlRpcValue all;
  all.setSize(0);
  for (const std::string& uri : listed) all[all.size()] = uri;
  for (const std::string& uri : extra)
    if (!listed.count(uri)) all[all.size()] = uri;
  XmlRpc::XmlRpcValue update, ignored;
  update[0] = std::string("/master");
  update[1] = topic;
  update[2] = all;
  callSelf("publisherUpdate", update, ignored);
}
}  // namespace

MasterWatch::MasterWatch(std::function<std::vector<std::string>()> services, double period)
    : services_(std::move(services)), period_(period)
{
}

MasterWatch::~MasterWatch()
{
  stop();
}

void MasterWatch::start()
{
  std::lock_guard<std::mutex> lock(mutex_);
  if (thread_.joinable() || stopping_) return;
  thread_ = std::thread([this] { run(); });
}

void MasterWatch::stop()
{
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  // stop() may come from two threads at once (the node's stop() and a start-up that ends, or a
  // thread's failure): one joins, the other waits for that. Once stopping_ is set, start() no
  // longer touches thread_.
  std::lock_guard<std::mutex> join_lock(join_mutex_);
  if (thread_.joinable() && thread_.get_id() != std::this_thread::get_id()) thread_.join();
}

int MasterWatch::reRegistrations() const
{
  std::lock_guard<std::mutex> lock(mutex_);
  return re_registrations_;
}

void MasterWatch::run()
{
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stopping_)
  {
    wake_.wait_for(lock, std::chrono::duration<double>(period_), [this] { return stopping_; });
    if (stopping_) break;
    lock.unlock();
    try
    {
      checkOnce();
    }
    catch (const std::exception& e)
    {
      // A failed check is retried at the next period; it must never end the node.
      ROS_WARN_THROTTLE(60.0, "fluid_sim: checking the ROS master failed: %s", e.what());
    }
    lock.lock();
  }
}

bool MasterWatch::checkOnce()
{
  // While roscpp shuts down it unregisters everything from the master, which then does not know
  // the node: that is no restart, and registering again then (through a slave API that is
  // stopping) hung the node's exit.
  if (!ros::ok() || ros::isShuttingDown()) return false;
  const std::string me = ros::this_node::getName();
  XmlRpc::XmlRpcValue params, result, payload;
  params[0] = me;
  params[1] = me;
  // lookupNode answers code 1 with our URI if the master knows us; -1 if it does not. No answer
  // at all (execute() false and an invalid result) means the master is unreachable.
  const bool known = ros::master::execute("lookupNode", params, result, payload, false);
  const bool answered = result.valid() && result.getType() == XmlRpc::XmlRpcValue::TypeArray;
  if (!answered)
  {
    if (master_reachable_)
      ROS_WARN(
          "fluid_sim: the ROS master at %s does not answer: the simulation runs on and connections already "
          "made keep flowing; the node registers again when a master is back",
          ros::master::getURI().c_str());
    master_reachable_ = false;
    return false;
  }
  if (known && std::string(payload) == ros::XMLRPCManager::instance()->getServerURI())
  {
    if (!master_reachable_) ROS_INFO("fluid_sim: the ROS master at %s answers again", ros::master::getURI().c_str());
    master_reachable_ = true;
    if (!kept_.empty()) keepLinks();
    return true;
  }
  master_reachable_ = true;
  if (!ros::ok() || ros::isShuttingDown() || !registerAll()) return false;
  int n;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    n = ++re_registrations_;
  }
  ROS_INFO(
      "fluid_sim: the ROS master at %s did not know this node (restarted?): topics, subscriptions and "
      "services registered again (%d time(s) since start)",
      ros::master::getURI().c_str(), n);
  return true;
}

bool MasterWatch::registerAll()
{
  bool ok = true;
  int published = 0, subscribed = 0, served = 0;
  for (const auto& [topic, type] : topicList("getPublications"))
  {
    XmlRpc::XmlRpcValue payload;
    if (registerWithMaster("registerPublisher", topic, type, payload))
      ++published;
    else
      ok = false;
  }
  // Read before any publisherUpdate below changes the links.
  const std::map<std::string, std::set<std::string>> connected = connectedPublishers();
  kept_.clear();
  retried_.clear();
  int kept = 0;
  for (const auto& [topic, type] : topicList("getSubscriptions"))
  {
    XmlRpc::XmlRpcValue publishers;
    if (!registerWithMaster("registerSubscriber", topic, type, publishers))
    {
      ok = false;
      continue;
    }
    ++subscribed;
    // The publishers the new master already knows: connect to them now (those that register
    // later are announced by the master itself). roscpp takes a publisherUpdate's list as the
    // complete one and drops the links to every publisher it leaves out, so the list also holds
    // the publishers the subscription is linked to now: nodes that do not register again with
    // the new master (robot_state_publisher, a nodelet manager's bond) keep flowing, as they do
    // to a rospy subscriber. A link to a publisher that has gone away is one roscpp itself keeps
    // retrying until a master's update leaves it out (keepLinks() then lets it go).
    const std::set<std::string> listed = uriSet(publishers);
    std::set<std::string> linked;
    if (const auto c = connected.find(topic); c != connected.end())
      for (const std::string& uri : c->second)
        if (!listed.count(uri)) linked.insert(uri);
    updatePublishers(topic, listed, linked);
    kept += static_cast<int>(linked.size());
    if (!linked.empty()) kept_[topic] = linked;
  }
  const std::string service_api =
      "rosrpc://" + ros::network::getHost() + ":" + std::to_string(ros::ConnectionManager::instance()->getTCPPort());
  for (const std::string& service : services_ ? services_() : std::vector<std::string>{})
  {
    if (!ros::ServiceManager::instance()->lookupServicePublication(service)) continue;  // no longer served
    XmlRpc::XmlRpcValue payload;
    if (registerWithMaster("registerService", service, service_api, payload))
      ++served;
    else
      ok = false;
  }
  ROS_DEBUG(
      "fluid_sim: registered %d publications, %d subscriptions (kept %d link(s) to publishers the master does not "
      "know), %d services",
      published, subscribed, kept, served);
  return ok;
}

void MasterWatch::keepLinks()
{
  // The master's own publisherUpdates (sent when a publisher registers with it or leaves) list
  // only the publishers it knows, so roscpp drops the links registerAll() kept. Each check puts
  // such a dropped link back, once: a publisher that does not link again by the next check has
  // gone away and is let go. One the master lists now is its to announce.
  const std::map<std::string, std::set<std::string>> connected = connectedPublishers();
  std::map<std::string, std::string> types;
  for (const auto& [topic, type] : topicList("getSubscriptions")) types[topic] = type;
  const std::set<std::string> none;
  for (auto it = kept_.begin(); it != kept_.end();)
  {
    const std::string& topic = it->first;
    std::set<std::string>& uris = it->second;
    std::set<std::string>& retried = retried_[topic];
    const auto type = types.find(topic);
    const auto c = connected.find(topic);
    const std::set<std::string>& linked = c != connected.end() ? c->second : none;
    bool missing = false;
    for (const std::string& uri : uris)
      if (linked.count(uri))
        retried.erase(uri);
      else
        missing = true;
    XmlRpc::XmlRpcValue publishers;
    if (type == types.end())  // no longer subscribed
      uris.clear();
    else if (missing && registerWithMaster("registerSubscriber", topic, type->second, publishers))
    {
      const std::set<std::string> listed = uriSet(publishers);
      bool restore = false;
      for (auto u = uris.begin(); u != uris.end();)
      {
        if (listed.count(*u))
          u = uris.erase(u);  // registered with the master again
        else if (linked.count(*u))
          ++u;
        else if (retried.count(*u))
        {
          ROS_INFO("fluid_sim: publisher %s of %s (not known to the ROS master) is gone", u->c_str(), topic.c_str());
          retried.erase(*u);
          u = uris.erase(u);
        }
        else
        {
          retried.insert(*u);
          restore = true;
          ++u;
        }
      }
      if (restore) updatePublishers(topic, listed, uris);
    }
    if (uris.empty())
    {
      retried_.erase(topic);
      it = kept_.erase(it);
    }
    else
      ++it;
  }
}

}  // namespace ros_bridge
}  // namespace fluid_sim
