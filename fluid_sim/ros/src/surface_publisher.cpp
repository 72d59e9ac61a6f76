#include "fluid_sim/ros/surface_publisher.h"

#include <tbb/task_arena.h>

#include <ros/console.h>
#include <visualization_msgs/Marker.h>

#include "fluid_sim/ros/messages.h"
#include "fluid_sim/ros/thread_guard.h"

namespace fluid_sim
{
namespace ros_bridge
{
SurfacePublisher::~SurfacePublisher()
{
  requestStop();
  join();
}

void SurfacePublisher::advertise(ros::NodeHandle& nh, double spacing)
{
  spacing_ = spacing;
  rate_ = opt_.surface_rate;
  pub_ = nh.advertise<visualization_msgs::Marker>("surface", 1);
}

void SurfacePublisher::setRate(double hz)
{
  std::lock_guard<std::mutex> lock(mutex_);
  rate_ = hz;
  // Off: the positions waiting for the surface thread are dropped, and run() checks the rate
  // again, under this lock, before it publishes the surface it was making, so that 0 takes effect
  // at once and not one or two reconstructions later.
  if (!(hz > 0.0)) ready_ = false;
}

void SurfacePublisher::offer(const ros::Time& stamp, const std::vector<Vec3>& positions)
{
  const double rate = rate_;
  if (!(rate > 0.0) || !pub_ || pub_.getNumSubscribers() == 0) return;  // off: nothing is made
  // Due by the frames' stamps (ROS time when paced, as publish_rate counts): at most `rate` per
  // second whatever the frame rate; a stamp earlier than the last (reset, ROS time jumped back)
  // starts afresh.
  if (!last_offer_.isZero() && stamp >= last_offer_ && (stamp - last_offer_).toSec() < 1.0 / rate - 1e-9) return;
  last_offer_ = stamp;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    pending_.assign(positions.begin(), positions.end());  // 12 bytes a particle: 0.04 MB for the demo
    pending_stamp_ = stamp;
    ready_ = true;
  }
  cv_.notify_one();
}

void SurfacePublisher::start(std::function<void(const std::string&)> on_failure)
{
  thread_ = std::thread([this, on_failure = std::move(on_failure)] {
    runGuarded(
        "surface", [this] { run(); }, on_failure);
  });
}

void SurfacePublisher::requestStop()
{
  {
    // Under the lock: the thread may have checked stopping_ just before it is set.
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  cv_.notify_all();
}

void SurfacePublisher::join()
{
  if (thread_.joinable()) thread_.join();
}

void SurfacePublisher::run()
{
  // One thread's worth of work, never the solver's: TBB's workers stay with the solver's loops
  // (OpenVDB would otherwise spread a reconstruction over the same workers the next step needs).
  tbb::task_arena arena(1);
  std::vector<Vec3> positions;
  while (true)
  {
    ros::Time stamp;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      cv_.wait(lock, [&] { return ready_ || stopping_.load(); });
      if (stopping_) return;
      std::swap(positions, pending_);
      stamp = pending_stamp_;
      ready_ = false;
    }
    SurfaceMesh mesh;
    try
    {
      arena.execute([&] { mesh = reconstructSurface(positions, spacing_, options_); });
    }
    catch (const ConfigError& e)
    {
      // The voxel budget (a particle far from the rest): this surface is left out, the node goes on.
      ROS_WARN_THROTTLE(10.0, "fluid_sim: no surface at %.3f: %s", stamp.toSec(), e.what());
      continue;
    }
    if (mesh.skipped_particles > 0)
      ROS_WARN_THROTTLE(10.0, "fluid_sim: surface at %.3f: %zu particles with a non-finite position left out",
                        stamp.toSec(), mesh.skipped_particles);
    // A new message each time: nodelet subscribers may keep the previous one (zero copy).
    boost::shared_ptr<visualization_msgs::Marker> marker(new visualization_msgs::Marker);
    marker->header.stamp = stamp;
    marker->header.frame_id = opt_.fixed_frame;
    fillSurfaceMarker(mesh, *marker);
    {
      // Switched off while this surface was made (setRate()): it is not published. Under the
      // lock, so that once setRate(0) has returned nothing more comes out.
      std::lock_guard<std::mutex> lock(mutex_);
      if (!(rate_.load() > 0.0)) continue;
      pub_.publish(marker);
    }
    ROS_DEBUG("fluid_sim: surface of %zu particles: %zu triangles in %.1f ms", mesh.particles, mesh.triangles.size(),
              mesh.ms);
  }
}

}  // namespace ros_bridge
}  // namespace fluid_sim
