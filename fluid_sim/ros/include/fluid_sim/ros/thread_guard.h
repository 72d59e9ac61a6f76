#pragma once
// The top of the node's own threads (solver, publisher): whatever escapes a thread's body is
// caught there, logged with the thread's name and the cause, and reported, so that it never
// ends the process through std::terminate without a word.

#include <functional>
#include <string>

namespace fluid_sim
{
namespace ros_bridge
{
/// Runs `body`. Anything it throws is caught and logged with ROS_FATAL ("fluid_sim: the <thread>
/// thread stopped: <cause>"); `on_failure` (if set) then gets that message. Returns false if
/// something was thrown.
bool runGuarded(const std::string& thread, const std::function<void()>& body,
                const std::function<void(const std::string&)>& on_failure);

}  // namespace ros_bridge
}  // namespace fluid_sim
