// The node as a nodelet (fluid_sim/FluidSimNodelet): subscribers in the same manager receive the
// particle clouds without serialisation. A configuration error is logged and the nodelet stays
// idle (it cannot end the manager's process).
#include <memory>
#include <thread>

#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include "fluid_sim/ros/fluid_sim_node.h"

namespace fluid_sim
{
namespace ros_bridge
{
class FluidSimNodelet : public nodelet::Nodelet
{
public:
  ~FluidSimNodelet() override
  {
    if (node_) node_->stop();
    if (starter_.joinable()) starter_.join();
  }

private:
  void onInit() override
  {
    node_ = std::make_unique<FluidSimNode>(getMTNodeHandle(), getMTPrivateNodeHandle());
    node_->onFinished(
        [this](int code) { NODELET_INFO("fluid_sim nodelet finished (code %d); it stays loaded, idle", code); });
    // start() waits for tf; onInit must return promptly.
    starter_ = std::thread([this] {
      try
      {
        node_->start();
      }
      catch (const std::exception& e)
      {
        NODELET_FATAL("fluid_sim: %s", e.what());
      }
      catch (...)
      {
        NODELET_FATAL("fluid_sim: start-up stopped on an exception that is not a std::exception");
      }
    });
  }

  std::unique_ptr<FluidSimNode> node_;
  std::thread starter_;
};
}  // namespace ros_bridge
}  // namespace fluid_sim

PLUGINLIB_EXPORT_CLASS(fluid_sim::ros_bridge::FluidSimNodelet, nodelet::Nodelet)
