// fluid_sim_demo_motion: drives a robot's joints for demos and tests by publishing
// sensor_msgs/JointState on `joint_states` (robot_state_publisher turns them into tf).
// Each joint follows  q(t) = offset + velocity * t + amplitude * sin(2 pi frequency t + phase),
// in rad (m for prismatic joints), t in s of ROS time since start.
//
// Private parameters (lists of equal length, one entry per joint; absent lists are zeros):
//   joints [string], offsets, velocities (rad/s), amplitudes, frequencies (Hz), phases (rad);
//   rate (Hz, default 100); epoch (s of ROS time that counts as t = 0; default: this node's
//   start). With an epoch, a restarted demo_motion carries on where the last one was.
#include <cmath>
#include <string>
#include <vector>

#include <ros/ros.h>
#include <sensor_msgs/JointState.h>

int main(int argc, char** argv)
{
  ros::init(argc, argv, "demo_motion");
  ros::NodeHandle nh, pnh("~");
  std::vector<std::string> joints;
  if (!pnh.getParam("joints", joints) || joints.empty())
  {
    ROS_FATAL("demo_motion: parameter %s/joints (a list of joint names) is required", pnh.getNamespace().c_str());
    return 1;
  }
  auto list = [&](const char* name) {
    std::vector<double> v;
    pnh.param(name, v, v);
    if (v.empty()) v.assign(joints.size(), 0.0);
    if (v.size() != joints.size())
    {
      ROS_FATAL("demo_motion: parameter %s/%s has %zu entries, joints has %zu", pnh.getNamespace().c_str(), name,
                v.size(), joints.size());
      std::exit(1);
    }
    return v;
  };
  const std::vector<double> offsets = list("offsets"), velocities = list("velocities"), amplitudes = list("amplitudes"),
                            frequencies = list("frequencies"), phases = list("phases");
  double rate = 100.0;
  pnh.param("rate", rate, rate);
  ros::Publisher pub = nh.advertise<sensor_msgs::JointState>("joint_states", 10);
  // With use_sim_time, ROS time is 0 until the first /clock message.
  while (ros::ok() && ros::Time::now().isZero()) ros::WallDuration(0.01).sleep();
  double epoch = 0.0;
  pnh.param("epoch", epoch, epoch);
  if (!std::isfinite(epoch) || epoch < 0.0)
  {
    ROS_FATAL("demo_motion: parameter %s/epoch = %g: must be a ROS time in s (>= 0)", pnh.getNamespace().c_str(),
              epoch);
    return 1;
  }
  const ros::Time start = epoch > 0.0 ? ros::Time(epoch) : ros::Time::now();
  ros::Rate loop(rate);
  const double two_pi = 2.0 * M_PI;
  while (ros::ok())
  {
    const ros::Time now = ros::Time::now();
    const double t = (now - start).toSec();
    sensor_msgs::JointState js;
    js.header.stamp = now;
    js.name = joints;
    for (std::size_t k = 0; k < joints.size(); ++k)
    {
      const double w = two_pi * frequencies[k];
      js.position.push_back(offsets[k] + velocities[k] * t + amplitudes[k] * std::sin(w * t + phases[k]));
      js.velocity.push_back(velocities[k] + amplitudes[k] * w * std::cos(w * t + phases[k]));
    }
    pub.publish(js);
    ros::spinOnce();
    loop.sleep();
  }
  return 0;
}
