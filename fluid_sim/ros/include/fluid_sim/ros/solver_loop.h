#pragma once
// The solver loop: owns the simulation and the thread that steps it, paced against ROS time
// (real_time_factor, tf_delay, the anchors that tie simulated time to ROS time), and takes the
// commands of the services and of dynamic_reconfigure (pause, step, reset, new settings)
// between two steps. Link poses come from LinkPoses before each step; frames go to Publishers
// after it.

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <ros/time.h>

#include "fluid_sim/FluidSimConfig.h"
#include "fluid_sim/core/measurements.h"
#include "fluid_sim/core/simulation.h"
#include "fluid_sim/ros/link_poses.h"
#include "fluid_sim/ros/node_parameters.h"
#include "fluid_sim/ros/publishers.h"

namespace fluid_sim
{
namespace ros_bridge
{
/// The answer to a command from a service.
struct CommandResult
{
  bool success = false;
  std::string message;
  double sim_time = 0.0;  // s, simulated time after the command (step only)
};

class SolverLoop
{
public:
  /// `opt` is read once by the node before any call below and must outlive the loop.
  SolverLoop(const NodeOptions& opt, LinkPoses& links, Publishers& publishers);
  /// Stops and joins the solver thread (a joinable thread must not be destroyed).
  ~SolverLoop();
  SolverLoop(const SolverLoop&) = delete;
  SolverLoop& operator=(const SolverLoop&) = delete;

  /// The scene without the robot and the robot's links (shapes in link frames); the live
  /// settings start from the node options.
  void setScene(SceneConfig scene, std::vector<BoundaryConfig> link_bodies);

  /// Names of the links posed from tf (not the free ones).
  std::vector<std::string> linkNames() const;
  /// The tf frames the node needs before it starts: the links posed from tf and the frames
  /// emitters are fixed in (emitters[i].frame), each once.
  std::vector<std::string> tfFrames() const;
  /// Names of the links that are free bodies (~free_links): the simulation moves them.
  std::set<std::string> freeLinkNames() const;

  /// Builds the simulation with the link bodies at `poses`, tf's poses at the ROS instant
  /// `poses_stamp` (zero: now, e.g. static frames); simulated t = 0 is tied to that instant.
  /// Throws StartupError.
  void build(const std::map<std::string, Pose>& poses, const ros::Time& poses_stamp);

  /// The simulation (before start(), or from the solver thread).
  const Simulation& simulation() const
  {
    return *sim_;
  }

  /// Called once from the solver thread when the run ends by itself (see FluidSimNode).
  void onFinished(std::function<void(int)> callback)
  {
    on_finished_ = std::move(callback);
  }

  /// Called once from the solver thread if something thrown there ended it (after it was
  /// logged with ROS_FATAL), with the logged message.
  void onFailure(std::function<void(const std::string&)> callback)
  {
    on_failure_ = std::move(callback);
  }

  /// True once requestStop() was called.
  const std::atomic<bool>& stopping() const
  {
    return stopping_;
  }

  /// Starts the solver thread.
  void start();
  /// Tells the solver thread to end; false if that was already asked.
  bool requestStop();
  /// Waits for the solver thread to end.
  void join();

  // Commands, from any thread; each is applied by the solver thread between two steps.
  /// Rebuilds the scene with the newest link poses; returns when done (or after 120 s).
  CommandResult reset();
  /// Pauses (true) or resumes (false); a resume restarts the pacing from now and cancels steps
  /// still queued by step().
  CommandResult pause(bool paused);
  /// Takes `steps` steps while paused; returns when they are done. It waits at most
  /// kStepServiceWait: then the steps not yet taken are cancelled (not left running after the
  /// call has returned), as they are by a resume, a reset, an unstable step or shutdown; the
  /// message then says how many were taken and why the rest were not.
  CommandResult step(unsigned steps);
  static constexpr int kStepServiceWait = 300;  // s
  /// New live settings: publish_rate and real_time_factor at once, solver and viscosity
  /// settings before the next step.
  void reconfigure(const fluid_sim::FluidSimConfig& config);

private:
  using WallClock = std::chrono::steady_clock;

  void run();
  void applyCommands();
  /// `paced_rtf`: the real-time factor of a paced step (its frames are stamped on ROS time's
  /// line, see rosInstant), 0 for a free-running or requested step (stamped now).
  void afterStep(const StepReport& report, double paced_rtf);
  void publishFrame(const StepReport& report, double paced_rtf);
  /// Paced: waits until tf has every link's pose at `stamp` (a tf publisher that is late, or
  /// stopped and restarted: tf2 then interpolates across the gap, so the links move on smoothly
  /// instead of jumping). False if a stop, reset, pause or re-anchoring came meanwhile.
  bool waitForTf(const ros::Time& stamp);
  /// The ROS instant of simulated time `sim_t` when paced at factor `rtf` > 0.
  ros::Time rosInstant(double sim_t, double rtf) const;
  /// The ROS instant to pose the links at for the step from simulated time `t`.
  ros::Time poseStamp(double t);
  void publishPausedStats();
  /// While a step waits for tf (waitForTf) more than a second: the last step's stats, stamped
  /// now, with status "waiting_for_tf: <link>", at most one a second, so that a monitor of stats
  /// sees why nothing moves.
  void publishWaitingStats(const std::string& link);
  void printSummary();

  const NodeOptions& opt_;
  LinkPoses& links_;
  Publishers& publishers_;
  std::function<void(int)> on_finished_;
  std::function<void(const std::string&)> on_failure_;

  // Scene and simulation. `base_scene_` has the scene's own bodies; link bodies are appended
  // with the poses tf gives at (re)start.
  SceneConfig base_scene_;
  std::vector<BoundaryConfig> link_configs_;  // shapes in link frames, from the URDF
  std::unique_ptr<Simulation> sim_;

  // Commands from service and reconfigure callbacks, applied by the solver thread between steps.
  std::mutex cmd_mutex_;
  std::condition_variable cmd_cv_;
  // Written under cmd_mutex_ (the condition variable's predicates read it there); atomic so
  // that the solver thread may read it without the lock (publishFrame).
  std::atomic<bool> paused_{false};
  // A step went unstable (under cmd_mutex_): the simulation is paused until a reset, which
  // resumes it when it was running then (not when it was stepping on request, paused); a resume
  // or a step before it is refused (it would step the blown-up state on).
  bool unstable_ = false;
  bool resume_after_reset_ = false;
  bool reset_requested_ = false;
  bool reset_done_ = false;
  std::string reset_error_;
  unsigned steps_requested_ = 0;
  std::uint64_t steps_done_counter_ = 0;
  std::uint64_t steps_cancelled_ = 0;  // how often queued steps were dropped (wakes waiting step calls)
  std::optional<fluid_sim::FluidSimConfig> pending_config_;
  bool reanchor_ = true;   // pacing restarts from the current instants (start, resume, reset, rtf change)
  ros::Time built_at_;     // ROS instant of the poses build() placed the links at; zero once the anchor used it
  double catch_up_ = 0.0;  // s, how far behind ROS time an anchor at built_at_ started
  // s; the links are never looked up further back than this (LinkPoses' tf buffer keeps 60 s),
  // nor is the start anchored further back at the build's instant.
  static constexpr double kMaxPoseLag = 30.0;

  // Live settings (reconfigurable).
  std::atomic<double> publish_rate_{30.0};     // Hz
  std::atomic<double> real_time_factor_{1.0};  // simulated s per ROS s; 0 = as fast as it can

  std::atomic<bool> stopping_{false};
  std::thread thread_;

  // Solver-thread state: pacing.
  // The time line (solver thread only): simulated time anchor_sim_ is ROS time anchor_ros_, and
  // runs at anchor_rtf_ (0: one to one, as fast as it can). Valid from the first anchoring until a
  // rebuild or a jump back of ROS time; resume and a new factor carry it on.
  bool timeline_valid_ = false;
  double anchor_rtf_ = 1.0;
  ros::Time last_pose_stamp_;                                   // the instant the links were last posed at
  double last_pose_sim_ = 0.0;                                  // s, the simulated time of that step
  ros::Time anchor_ros_;                                        // ROS time of simulated time anchor_sim_
  double anchor_sim_ = 0.0;                                     // s, simulated
  double next_publish_sim_ = 0.0;                               // s, simulated instant of the next frame (paced mode)
  WallClock::time_point next_publish_wall_ = WallClock::now();  // of the next frame (other modes)
  // Real-time factor over about a second of wall time.
  WallClock::time_point rtf_wall0_ = WallClock::now();
  double rtf_sim0_ = 0.0;      // s, simulated time at rtf_wall0_
  double rtf_measured_ = 0.0;  // simulated s per wall s
  // The measuring window started at the start or at a re-anchoring (a resume, a new factor) and is
  // not a second long yet: rtf_measured_ is taken over it so far.
  bool rtf_first_window_ = true;

  // Solver-thread state: frames.
  bool boundary_dirty_ = true;        // the boundary cloud must be (re)published
  std::vector<Pose> boundary_poses_;  // each body's pose when the boundary cloud last went out
  double last_frame_sim_ = -1.0;      // s, simulated time of the last frame published (-1: none since the build)
  // Stamp of the last frame (zero after a build or a jump of ROS time): a frame is never stamped
  // earlier (switching real_time_factor from 0 to paced put the next stamps on a time line 0.1 s
  // behind the last).
  ros::Time last_frame_stamp_;
  std::vector<std::pair<std::size_t, std::size_t>> body_ranges_;  // boundary particles of each body
  WrenchMeans wrench_means_;
  std::vector<fluid_msgs::ContactWrench> last_wrenches_;  // the last valid frame's, for printSummary()
  // The scene's instruments, measured once per published frame (the probes after every step when
  // averaged over ~probe_window); null for a scene without any.
  std::unique_ptr<Measurements> measurements_;
  ProbeMeans probe_means_;
  bool probeWindowed() const
  {
    return measurements_ && !measurements_->probes().empty() && opt_.probe_window > 0.0;
  }
  StepReport last_report_;
  // Written by the solver thread under cmd_mutex_ (after each step, on reset), read by the
  // step service under it; the solver thread reads them without the lock.
  std::string last_status_ = "ok";
  double sim_time_ = 0.0;                    // s, simulated time after the last step (a copy of sim_->time())
  WallClock::time_point last_paused_stats_;  // stats while paused or waiting for tf: at most one a second
  ros::Time last_seen_now_;                  // ROS time when the pacing last looked (a jump back is below it)
  WallClock::time_point last_seen_wall_;     // wall time then (a jump forward outruns it)

  // Run statistics (for the summary printed at the end).
  std::uint64_t steps_ = 0, frames_ = 0;
  double sum_divergence_iterations_ = 0, sum_density_iterations_ = 0;
  double sum_step_ms_ = 0, sum_copy_ms_ = 0;  // ms: stepping, and copying frames out
  // The wall guard (solver.wall_guard, Eq. A31): steps it acted in, particles it held in them.
  std::uint64_t wall_guarded_steps_ = 0, sum_wall_guarded_ = 0;
  WallClock::time_point run_start_ = WallClock::now();
};

}  // namespace ros_bridge
}  // namespace fluid_sim
