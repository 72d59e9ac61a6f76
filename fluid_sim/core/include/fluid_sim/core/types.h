#pragma once
// Basic numeric types shared by every layer. ROS-free: Eigen only.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace fluid_sim
{
#ifdef FLUID_SIM_USE_DOUBLE
using Real = double;
#else
using Real = float;
#endif

using Vec3 = Eigen::Matrix<Real, 3, 1>;
using Vec4 = Eigen::Matrix<Real, 4, 1>;  // a Vec3 padded with a 0 for packed arithmetic
using Vec4Array = std::vector<Vec4, Eigen::aligned_allocator<Vec4>>;
using Mat3 = Eigen::Matrix<Real, 3, 3>;
using Vec3d = Eigen::Vector3d;
using Mat3d = Eigen::Matrix3d;
using Index = std::uint32_t;

/// Rigid transform from a body frame to the world frame: x_world = rotation * x_body + translation.
/// Kept in double so that composing many poses (scripted motion, tf) does not drift.
struct Pose
{
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Vec3d translation = Vec3d::Zero();  // m

  Vec3d apply(const Vec3d& p) const
  {
    return rotation * p + translation;
  }
  static Pose fromXyzRpy(const Vec3d& xyz, const Vec3d& rpy)
  {
    Pose pose;
    // URDF convention: fixed-axis roll (x), pitch (y), yaw (z): R = Rz(yaw) Ry(pitch) Rx(roll).
    pose.rotation = Eigen::AngleAxisd(rpy.z(), Vec3d::UnitZ()) * Eigen::AngleAxisd(rpy.y(), Vec3d::UnitY()) *
                    Eigen::AngleAxisd(rpy.x(), Vec3d::UnitX());
    pose.translation = xyz;
    return pose;
  }
  /// From a translation (m) and a rotation quaternion (w, x, y, z), normalised here: the form of
  /// URDF origins and tf transforms.
  static Pose fromTranslationQuaternion(const Vec3d& xyz, double qw, double qx, double qy, double qz)
  {
    Pose pose;
    pose.translation = xyz;
    pose.rotation = Eigen::Quaterniond(qw, qx, qy, qz).normalized();
    return pose;
  }
  Pose operator*(const Pose& other) const
  {
    Pose out;
    out.rotation = (rotation * other.rotation).normalized();
    out.translation = rotation * other.translation + translation;
    return out;
  }
};

/// A bad scene or bad input. `key` is the dotted scene key (or link/file) at fault; `what()` names it.
class ConfigError : public std::runtime_error
{
public:
  ConfigError(const std::string& key, const std::string& message)
      : std::runtime_error(key.empty() ? message : key + ": " + message), key_(key), message_(message)
  {
  }
  const std::string& key() const
  {
    return key_;
  }
  const std::string& message() const
  {
    return message_;
  }

private:
  std::string key_;
  std::string message_;
};

}  // namespace fluid_sim
