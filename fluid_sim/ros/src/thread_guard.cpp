#include "fluid_sim/ros/thread_guard.h"

#include <exception>

#include <ros/console.h>

namespace fluid_sim
{
namespace ros_bridge
{
bool runGuarded(const std::string& thread, const std::function<void()>& body,
                const std::function<void(const std::string&)>& on_failure)
{
  std::string cause;
  try
  {
    body();
    return true;
  }
  catch (const std::exception& e)
  {
    cause = e.what();
  }
  catch (...)
  {
    cause = "an exception that is not a std::exception";
  }
  const std::string message = "fluid_sim: the " + thread + " thread stopped: " + cause + "; shutting down";
  ROS_FATAL("%s", message.c_str());
  if (on_failure)
  {
    try
    {
      on_failure(message);
    }
    catch (...)
    {
      ROS_FATAL("fluid_sim: reporting the failure of the %s thread failed too", thread.c_str());
    }
  }
  return false;
}

}  // namespace ros_bridge
}  // namespace fluid_sim
