#include "fluid_sim/ros/solver_loop.h"

#include <algorithm>
#include <cstdio>
#include <sstream>

#include <ros/console.h>
#include <ros/duration.h>

#include "fluid_sim/ros/fluid_sim_node.h"
#include "fluid_sim/ros/messages.h"
#include "fluid_sim/ros/thread_guard.h"

namespace fluid_sim
{
namespace ros_bridge
{
namespace
{
double msSince(std::chrono::steady_clock::time_point t0)
{
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

SolverLoop::SolverLoop(const NodeOptions& opt, LinkPoses& links, Publishers& publishers)
    : opt_(opt), links_(links), publishers_(publishers)
{
}

SolverLoop::~SolverLoop()
{
  requestStop();
  join();
}

void SolverLoop::setScene(SceneConfig scene, std::vector<BoundaryConfig> link_bodies)
{
  base_scene_ = std::move(scene);
  link_configs_ = std::move(link_bodies);
  publish_rate_ = opt_.publish_rate;
  real_time_factor_ = opt_.real_time_factor;
}

std::vector<std::string> SolverLoop::linkNames() const
{
  std::vector<std::string> names;
  for (const BoundaryConfig& b : link_configs_)
    if (!b.dynamic.enabled) names.push_back(b.name);
  return names;
}

std::vector<std::string> SolverLoop::tfFrames() const
{
  std::vector<std::string> frames = linkNames();
  for (const EmitterConfig& e : base_scene_.emitters)
    if (!e.frame.empty() && std::find(frames.begin(), frames.end(), e.frame) == frames.end()) frames.push_back(e.frame);
  return frames;
}

std::set<std::string> SolverLoop::freeLinkNames() const
{
  std::set<std::string> names;
  for (const BoundaryConfig& b : link_configs_)
    if (b.dynamic.enabled) names.insert(b.name);
  return names;
}

void SolverLoop::build(const std::map<std::string, Pose>& poses, const ros::Time& poses_stamp)
{
  SceneConfig scene = base_scene_;
  for (BoundaryConfig b : link_configs_)
  {
    // A free link (~free_links) starts, at every build, from its URDF pose (readRobotLinks); tf
    // would give back only where the node itself last put it.
    if (!b.dynamic.enabled) b.pose = poses.at(b.name);
    scene.boundaries.push_back(std::move(b));
  }
  // The poses are tf's at poses_stamp (LinkPoses::posesAtOneInstant); the construction (the
  // fill's relaxation: up to seconds) takes a while, during which the links move on. Simulated
  // t = 0 is tied to the poses' instant (see the anchoring in run()), not to the end of the
  // construction, so that the first step finds the links where the water was placed around them.
  // Anchored at the end instead, the demo's paddle, turning at 1.5 rad/s, jumped 0.3-0.5 rad
  // through the settled water in its first step and every particle became NaN in the second.
  const ros::Time now = ros::Time::now();
  built_at_ = (poses_stamp.isZero() || poses_stamp > now) ? now : poses_stamp;
  timeline_valid_ = false;  // a new scene: a new time line, from built_at_
  try
  {
    auto next = std::make_unique<Simulation>(scene);
    for (const std::string& warning : next->startWarnings()) ROS_WARN("%s", warning.c_str());
    // The instruments (a region's body may be a URDF link): before anything is replaced.
    auto instruments = std::make_unique<Measurements>(*next);
    sim_ = std::move(next);
    measurements_ = instruments->empty() ? nullptr : std::move(instruments);
  }
  catch (const ConfigError& e)
  {
    // Named as readScene() names the loader's errors: the scene's source, then the key.
    throw StartupError("scene: " + scene.source + ": " + withoutYamlLines(e.what()));
  }
  const FillReport& fill = sim_->fillReport();
  if (fill.trimmed > 0 || fill.relaxed)
    ROS_INFO("fill: %zu lattice points trimmed at walls; relaxed from %.3g %% to %.3g %% in %d pseudo-steps (%.0f ms)",
             fill.trimmed, 100.0 * fill.initial_density_error, 100.0 * fill.final_density_error, fill.relax_steps,
             fill.ms_relax);
  if (fill.overlapped > 0)
    ROS_INFO(
        "fill: %zu lattice points left out where an earlier fluid block's water lies (overlapping blocks make "
        "their union)",
        fill.overlapped);
  if (!fill.settled && !scene.fill.relax)
    ROS_WARN(
        "fill: fill.relax is off and the lattice is %.3g %% from rest density (fill.relax_tolerance %.3g %%): it "
        "starts unsettled and will move at t = 0",
        100.0 * fill.final_density_error, 100.0 * scene.fill.relax_tolerance);
  else if (!fill.settled)
    ROS_WARN(
        "fill: the relaxation stopped at fill.relax_max_steps = %d with the water %.3g %% from rest density "
        "(fill.relax_tolerance %.3g %%): it starts unsettled and will move at t = 0; raise fill.relax_max_steps",
        scene.fill.relax_max_steps, 100.0 * fill.final_density_error, 100.0 * scene.fill.relax_tolerance);
  links_.attach(*sim_, linkNames(), poses);
  links_.attachEmitters(*sim_, poses);
  const std::size_t nb = sim_->numBodies();
  body_ranges_.clear();
  for (std::size_t k = 0; k < nb; ++k)
  {
    const BodyInfo b = sim_->body(k);
    body_ranges_.emplace_back(b.first_particle, b.num_particles);
  }
  wrench_means_.reset(nb);
  last_wrenches_.clear();
  wrench_means_.setWindow(opt_.wrench_window);
  probe_means_.reset();
  probe_means_.setWindow(opt_.probe_window);
  sim_time_ = sim_->time();  // build() runs before start() or under cmd_mutex_ (reset)
  boundary_dirty_ = true;
  last_frame_sim_ = -1.0;
  last_frame_stamp_ = ros::Time();
  reanchor_ = true;
  rtf_sim0_ = 0.0;
  rtf_wall0_ = WallClock::now();
}

// ------------------------------------------------------------------------------ thread
void SolverLoop::start()
{
  run_start_ = WallClock::now();
  // Nothing thrown in the solver thread (a ros::Duration out of range, bad_alloc, ...) may end
  // the process unexplained: it is logged and reported (the node then shuts down).
  thread_ = std::thread([this] {
    runGuarded(
        "solver", [this] { run(); }, on_failure_);
  });
}

bool SolverLoop::requestStop()
{
  std::lock_guard<std::mutex> lock(cmd_mutex_);
  if (stopping_.exchange(true)) return false;
  cmd_cv_.notify_all();
  return true;
}

void SolverLoop::join()
{
  if (thread_.joinable()) thread_.join();
}

// ------------------------------------------------------------------------------ commands
CommandResult SolverLoop::reset()
{
  std::unique_lock<std::mutex> lock(cmd_mutex_);
  reset_requested_ = true;
  reset_done_ = false;
  cmd_cv_.notify_all();
  cmd_cv_.wait_for(lock, std::chrono::seconds(120), [&] { return reset_done_ || stopping_.load(); });
  CommandResult r;
  r.success = reset_done_ && reset_error_.empty();
  r.message = !reset_done_ ? "reset timed out" : reset_error_.empty() ? "reset to the initial scene" : reset_error_;
  return r;
}

CommandResult SolverLoop::pause(bool paused)
{
  std::lock_guard<std::mutex> lock(cmd_mutex_);
  if (unstable_ && !paused)
  {
    CommandResult r;
    r.success = false;
    r.message = "the simulation became unstable (" + last_status_ + "): call ~reset first";
    r.sim_time = sim_time_;
    return r;
  }
  if (paused_ && !paused) reanchor_ = true;  // resume: pacing restarts from where it stopped
  if (!paused && steps_requested_ > 0)
  {
    steps_requested_ = 0;  // a resume ends stepping on request; the waiting calls say so
    ++steps_cancelled_;
  }
  paused_ = paused;
  cmd_cv_.notify_all();
  CommandResult r;
  r.success = true;
  r.message = paused_ ? "paused" : "running";
  return r;
}

CommandResult SolverLoop::step(unsigned steps)
{
  std::unique_lock<std::mutex> lock(cmd_mutex_);
  CommandResult r;
  r.sim_time = sim_time_;  // refusals say where the simulation stands too
  if (unstable_)
  {
    r.success = false;
    r.message = "the simulation became unstable (" + last_status_ + "): call ~reset first";
    return r;
  }
  if (!paused_)
  {
    r.success = false;
    r.message = "the simulation is running: pause it first (service pause, data: true)";
    return r;
  }
  if (steps == 0)
  {
    r.success = false;
    r.message = "steps must be at least 1";
    return r;
  }
  const std::uint64_t first = steps_done_counter_ + steps_requested_;  // steps queued before these
  const std::uint64_t target = first + steps;
  const std::uint64_t cancelled = steps_cancelled_;
  steps_requested_ += steps;
  cmd_cv_.notify_all();
  const bool ended = cmd_cv_.wait_for(lock, std::chrono::seconds(kStepServiceWait), [&] {
    return steps_done_counter_ >= target || stopping_.load() || !paused_ || steps_cancelled_ != cancelled;
  });
  r.success = steps_done_counter_ >= target;
  if (!r.success)
  {
    std::string why = "the node is shutting down";
    if (!ended)
    {
      // Not left running after the call returned: whoever asked is no longer waiting for them.
      why = "the service waits at most " + std::to_string(kStepServiceWait) + " s; the rest were cancelled";
      steps_requested_ = 0;
      ++steps_cancelled_;
      cmd_cv_.notify_all();
    }
    else if (steps_cancelled_ != cancelled || !paused_)
      why = "cancelled by a resume, a reset, an unstable step or another call's time-out";
    const std::uint64_t taken = steps_done_counter_ > first ? steps_done_counter_ - first : 0;
    r.message = "interrupted after " + std::to_string(taken) + " of " + std::to_string(steps) + " steps: " + why;
  }
  else
    r.message = last_status_;
  // Not sim_->time(): once resumed, the solver steps without cmd_mutex_ (a copy written under it).
  r.sim_time = sim_time_;
  return r;
}

void SolverLoop::reconfigure(const fluid_sim::FluidSimConfig& config)
{
  publish_rate_ = config.publish_rate;
  std::lock_guard<std::mutex> lock(cmd_mutex_);
  if (config.real_time_factor != real_time_factor_.load())
  {
    real_time_factor_ = config.real_time_factor;
    reanchor_ = true;
  }
  pending_config_ = config;
}

/// Applies a pending reset and pending settings. Called by the solver thread with cmd_mutex_ held.
void SolverLoop::applyCommands()
{
  if (reset_requested_)
  {
    reset_requested_ = false;
    if (steps_requested_ > 0)
    {
      steps_requested_ = 0;  // a reset drops steps still queued: they were meant for the old state
      ++steps_cancelled_;
    }
    reset_error_.clear();
    ros::Time poses_stamp;
    const std::map<std::string, Pose> poses = links_.newestPoses(poses_stamp);
    const SolverConfig solver = sim_->scene().solver;
    const ViscosityConfig visc = sim_->scene().viscosity;
    const StabilityConfig stab = sim_->scene().stability;
    try
    {
      build(poses, poses_stamp);
      sim_->updateSettings(solver, visc, stab);  // live settings survive a reset
      // The per-step figures of the summary start again with the steps they are divided by.
      steps_ = 0;
      sum_divergence_iterations_ = sum_density_iterations_ = sum_step_ms_ = 0;
      wall_guarded_steps_ = sum_wall_guarded_ = 0;
      last_status_ = "ok";
      last_report_ = StepReport();  // the stats no longer show the blown-up step's speeds
      if (unstable_)
      {
        // "Paused; call ~reset to start again": it starts again (it stayed paused until a resume).
        unstable_ = false;
        if (resume_after_reset_)
        {
          paused_ = false;
          reanchor_ = true;
        }
      }
      ROS_INFO("reset: %zu fluid particles", sim_->numFluidParticles());
    }
    catch (const std::exception& e)
    {
      reset_error_ = std::string("reset failed: ") + e.what();
      ROS_ERROR("%s", reset_error_.c_str());
    }
    reset_done_ = true;
    cmd_cv_.notify_all();
  }
  if (pending_config_)
  {
    const fluid_sim::FluidSimConfig c = *pending_config_;
    pending_config_.reset();
    SolverConfig solver = sim_->scene().solver;
    ViscosityConfig visc = sim_->scene().viscosity;
    fromReconfigure(c, solver, visc);
    try
    {
      sim_->updateSettings(solver, visc, sim_->scene().stability);
      ROS_INFO(
          "settings: density_error %g, divergence_error %g, iterations %d..%d, warm_start %s (%s), viscosity %s %g "
          "(walls %g), publish_rate %g Hz, real_time_factor %g, max_points %d, surface_rate %g Hz",
          c.density_error, c.divergence_error, c.min_iterations, c.max_iterations, c.warm_start ? "on" : "off",
          c.warm_start_guess.c_str(), c.viscosity_model.c_str(), c.viscosity_coefficient, c.boundary_viscosity,
          c.publish_rate, c.real_time_factor, c.max_points, c.surface_rate);
    }
    catch (const ConfigError& e)
    {
      ROS_ERROR("dynamic_reconfigure: refused, the solver keeps its settings: %s", e.what());
    }
  }
}

// ------------------------------------------------------------------------------ the loop
void SolverLoop::run()
{
  bool finished = false;
  while (!stopping_)
  {
    bool stepping_on_request = false;
    bool jump = false;
    double rtf = 0.0;
    {
      std::unique_lock<std::mutex> lock(cmd_mutex_);
      applyCommands();
      if ((paused_ || finished) && steps_requested_ == 0)
      {
        // The links' motion during a pause is replayed after it (see the resume below): the node's
        // record keeps it when the pause outlasts tf's.
        const bool record = paused_ && timeline_valid_ && !last_pose_stamp_.isZero();
        lock.unlock();
        if (record) links_.keepHistory(last_pose_stamp_, ros::Time::now());
        publishPausedStats();
        std::unique_lock<std::mutex> relock(cmd_mutex_);
        cmd_cv_.wait_for(relock, std::chrono::milliseconds(200));
        continue;
      }
      stepping_on_request = paused_ && steps_requested_ > 0;
      rtf = real_time_factor_;
      if (reanchor_ && !stepping_on_request && rtf > 0.0 && ros::Time::now().isZero())
      {
        // use_sim_time and no /clock yet: ROS time is 0 until the first message.
        lock.unlock();
        ROS_INFO_THROTTLE(5.0, "waiting for /clock (use_sim_time is set)");
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
        continue;
      }
      // A step asked for while paused goes on along the time line; a fresh build (a reset while
      // paused) has none yet, so it is anchored here too, at the build's instant: anchored at
      // the earlier build's instant instead, the first requested step posed the links where they
      // had been then (4-6 cm off the water's hole for a link moving at 0.09 m/s; the run blew up).
      if (reanchor_ && (!stepping_on_request || !timeline_valid_))
      {
        const ros::Time now = ros::Time::now();
        if (timeline_valid_)
        {
          // Resume, or a new factor: the time line carries on from the instant the links were last
          // posed at, so they move on continuously; the robot's motion during a pause is replayed
          // while the simulation catches up. Re-anchored at now instead, the demo's paddle jumped
          // by all it had turned during the pause (and by the lag before it): NaN at once.
          anchor_ros_ = last_pose_stamp_ <= now ? last_pose_stamp_ : now;
          anchor_sim_ = last_pose_sim_;
          catch_up_ = (now - anchor_ros_).toSec();  // behind on purpose: not worth a warning
        }
        else
        {
          // A fresh build (start, reset) or ROS time that went back. Simulated time is ROS time
          // now; steps then trail ROS time by tf_delay (see the pacing below), so tf holds poses
          // on both sides of every instant looked up. A fresh build is anchored at the instant
          // its poses were taken (see build()) while tf still holds that instant: the loop then
          // catches up.
          anchor_sim_ = sim_->time();
          anchor_ros_ = now;
          if (!built_at_.isZero() && built_at_ <= now)
          {
            if ((now - built_at_).toSec() < kMaxPoseLag)
            {
              anchor_ros_ = built_at_;
              catch_up_ = (now - built_at_).toSec();  // behind by the build on purpose: not worth a warning
            }
            else
              ROS_WARN(
                  "building the simulation took %.1f s, longer than tf keeps poses for the start: the links "
                  "jump to where they are now in the first step",
                  (now - built_at_).toSec());
          }
          jump = true;
        }
        built_at_ = ros::Time();  // used once
        anchor_rtf_ = rtf;
        timeline_valid_ = true;
        reanchor_ = false;
        next_publish_sim_ = sim_->time();
        // The achieved factor is measured afresh from here: the last second's window held the
        // pause, and stats read 0.001 for a second after a resume while it ran at 1.2.
        rtf_sim0_ = sim_->time();
        rtf_wall0_ = WallClock::now();
        rtf_first_window_ = true;
      }
    }

    const double t = sim_->time();
    const double dt = sim_->nextTimeStep();
    // Paced (real_time_factor > 0): simulated time runs on ROS time's line, scaled by the factor
    // (rosInstant), and the links are posed from tf at the matching instants. With factor 1 the
    // simulation is in step with ROS time; with 0.5 a link's motion takes twice as long in ROS
    // time as in simulated time (it looks twice as fast to the water). Every factor starts from the
    // build's instant (see build()), so the first step finds the links where the water was placed.
    const bool paced = rtf > 0.0 && !stepping_on_request;
    const double frame_rtf = paced ? rtf : 0.0;  // frames stamped on the paced time line, or now
    if (paced)
    {
      // Pace: the step from t to t + dt may run once ROS time has passed the instant of t + dt,
      // plus the tf delay, so that tf already holds the poses at t.
      const ros::Time due = rosInstant(t + dt, rtf) + ros::Duration(opt_.tf_delay);
      while (!stopping_ && ros::ok())
      {
        const ros::Time now = ros::Time::now();
        // ROS time went back (a bag played again with --clock, a simulator restarted under
        // use_sim_time): behind the time line's anchor, or behind the last instant looked at
        // (waiting for the old time line to come round again would stall the node for as long).
        const bool back = now < anchor_ros_ || (!last_seen_now_.isZero() && now < last_seen_now_);
        const ros::Time before = last_seen_now_.isZero() ? anchor_ros_ : last_seen_now_;
        // Or forward (a bag skipped ahead, a simulator's clock set on): more than tf's reach the
        // node relies on (kMaxPoseLag) beyond the wall time since it last looked. Taken for lag,
        // every stamp stayed 1,000 s in the past and tf had no poses for them; a pause or a tf
        // outage advances ROS time with the wall clock and is no jump.
        const WallClock::time_point wall_now = WallClock::now();
        const double wall_gap =
            last_seen_now_.isZero() ? 0.0 : std::chrono::duration<double>(wall_now - last_seen_wall_).count();  // s
        const bool ahead = !back && !last_seen_now_.isZero() && (now - before).toSec() > kMaxPoseLag + wall_gap;
        last_seen_now_ = now;
        last_seen_wall_ = wall_now;
        if (now >= due && !back && !ahead) break;
        if (back || ahead)
        {
          ROS_WARN("ROS time jumped %s from %.3f to %.3f s; simulated time continues from there",
                   back ? "back" : "forward", before.toSec(), now.toSec());
          std::lock_guard<std::mutex> lock(cmd_mutex_);
          reanchor_ = true;
          timeline_valid_ = false;
          last_frame_stamp_ = ros::Time();  // the new time line's stamps may lie before the old ones
          break;
        }
        {
          std::lock_guard<std::mutex> lock(cmd_mutex_);
          if (reset_requested_ || paused_ || reanchor_) break;
        }
        const double wait = std::min((due - now).toSec(), 0.005);
        std::this_thread::sleep_for(std::chrono::duration<double>(std::max(wait, 1e-4)));
      }
      std::lock_guard<std::mutex> lock(cmd_mutex_);
      if (reset_requested_ || paused_ || reanchor_) continue;
      const double lag = (ros::Time::now() - due).toSec();
      // Behind by no more than the build took (see build()): the start's catch-up, not a loop that
      // cannot keep up; that one falls further behind and is warned about.
      if (lag <= 0.0) catch_up_ = 0.0;
      if (lag > 0.5 + catch_up_)
        ROS_WARN_THROTTLE(10.0,
                          "cannot keep up with real_time_factor %g: %.2f s behind ROS time (achieving %.2f simulated s "
                          "per wall-clock s); "
                          "lower real_time_factor, coarsen the spacing, or give it more cores",
                          rtf, lag, rtf_measured_);
    }

    // The links' instant. A step asked for while paused goes on along the same time line, without
    // waiting: past what tf has, the links keep their newest pose.
    const ros::Time pose_stamp = poseStamp(t);
    if (!stepping_on_request && !waitForTf(pose_stamp)) continue;
    last_pose_stamp_ = pose_stamp;
    last_pose_sim_ = t;
    if (stopping_) break;

    std::unique_lock<std::mutex> step_lock(cmd_mutex_, std::defer_lock);
    if (stepping_on_request) step_lock.lock();  // a step service call waits for these steps under it
    links_.poseBodies(*sim_, pose_stamp, jump);
    const StepReport rep = sim_->step();
    for (const std::string& notice : rep.notices) ROS_WARN("%s", notice.c_str());
    // What the step service reads, written under the lock (the only writer is this thread).
    if (!step_lock.owns_lock()) step_lock.lock();
    last_status_ = rep.unstable                                            ? "unstable: " + rep.reason
                   : (!rep.density_converged || !rep.divergence_converged) ? "not_converged"
                                                                           : "ok";
    sim_time_ = sim_->time();
    if (!stepping_on_request) step_lock.unlock();
    afterStep(rep, frame_rtf);  // its frame goes out before a step service call returns
    if (stepping_on_request)
    {
      // A resume or a time-out may have cancelled the queue while this step ran.
      if (steps_requested_ > 0) --steps_requested_;
      ++steps_done_counter_;
      cmd_cv_.notify_all();
      step_lock.unlock();
    }

    if (rep.unstable)
    {
      ROS_ERROR("simulation unstable at t = %.4f s: %s. Paused; call ~reset to start again.", rep.time,
                rep.reason.c_str());
      // Not twice for one step (afterStep may have published it): a second transform of a moving
      // or free body at the same stamp is TF_REPEATED_DATA to every tf listener.
      if (last_frame_sim_ != sim_->time()) publishFrame(rep, frame_rtf);
      std::lock_guard<std::mutex> lock(cmd_mutex_);
      unstable_ = true;
      resume_after_reset_ = !paused_;  // running, not stepping on request while paused
      paused_ = true;
      if (steps_requested_ > 0) ++steps_cancelled_;
      steps_requested_ = 0;
      cmd_cv_.notify_all();
      if (opt_.stop_after > 0.0)
      {
        finished = true;
        printSummary();
        if (on_finished_) on_finished_(3);
      }
      continue;
    }
    if (opt_.stop_after > 0.0 && !finished && sim_->time() >= opt_.stop_after - 1e-9)
    {
      // Not twice for one step (afterStep may have published it): a second transform of a moving
      // or free body at the same stamp is TF_REPEATED_DATA to every tf listener.
      if (last_frame_sim_ != sim_->time()) publishFrame(rep, frame_rtf);
      finished = true;
      printSummary();
      if (on_finished_) on_finished_(0);
    }
  }
}

bool SolverLoop::waitForTf(const ros::Time& stamp)
{
  if (links_.size() == 0) return true;
  const ros::Time start = ros::Time::now();
  const auto wall_start = WallClock::now();
  bool warned = false;
  while (!stopping_ && ros::ok())
  {
    ros::Time newest;
    const std::string link = links_.notYetAt(stamp, &newest);
    if (link.empty()) break;
    // A publisher a little late is waited for in silence; one that stopped is named.
    if (WallClock::now() - wall_start > std::chrono::seconds(1))
    {
      if (newest.isZero())
        ROS_WARN_THROTTLE(5.0, "tf: no pose of link '%s' at all: the simulation waits for it at t = %.3f s",
                          link.c_str(), sim_->time());
      else
        ROS_WARN_THROTTLE(5.0,
                          "tf: no pose of link '%s' at %.3f yet (its newest is %.1f s older): the simulation waits "
                          "for it at t = %.3f s",
                          link.c_str(), stamp.toSec(), (stamp - newest).toSec(), sim_->time());
      warned = true;
      publishWaitingStats(link);
    }
    {
      std::lock_guard<std::mutex> lock(cmd_mutex_);
      if (reset_requested_ || paused_ || reanchor_) return false;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  const double waited = (ros::Time::now() - start).toSec();  // s of ROS time
  if (warned)
    ROS_INFO(
        "tf: every link's pose is there again after %.1f s; the simulation goes on from t = %.3f s (and catches "
        "up)",
        waited, sim_->time());
  // Behind ROS time by the wait on purpose: the catch-up is not a loop that cannot keep up.
  if (waited > 0.0) catch_up_ += waited;
  return !stopping_;
}

ros::Time SolverLoop::rosInstant(double sim_t, double rtf) const
{
  return anchor_ros_ + ros::Duration((sim_t - anchor_sim_) / rtf);
}

ros::Time SolverLoop::poseStamp(double t)
{
  const double rtf = anchor_rtf_;  // the factor of the time line (the current one once anchored)
  // The instant of simulated time t on ROS time's line: paced, scaled by the factor; as fast as
  // it can (factor 0), one simulated second per ROS second from the anchor (the build's instant
  // at the start), so the links replay their tf motion from where the water was placed.
  ros::Time at = rtf > 0.0 ? rosInstant(t, rtf) : anchor_ros_ + ros::Duration(t - anchor_sim_);
  const ros::Time now = ros::Time::now();
  // Far behind ROS time the node keeps its own record of the links' poses (pose_history), which
  // covers `at` from before tf dropped it.
  links_.keepHistory(at, now);
  // Never further back than the poses go: tf keeps 60 s (taken 30 s back), the node's record as far
  // back as it reaches (at most pose_history). A simulation that falls behind by more has its links'
  // instant drawn along with ROS time, so that they move on continuously, faster than they do,
  // instead of jumping to their newest pose (the demo's paddle, jumping 60 s of motion on a loaded
  // machine, made every particle NaN).
  // (Without a link or tf-fixed nozzle to pose, or with only static ones, nothing is posed from an
  // instant: no clamp, and no warning about links.)
  if (now.toSec() > kMaxPoseLag && at < now - ros::Duration(kMaxPoseLag) && !links_.historyCovers(at) &&
      !links_.posesHoldAtAnyInstant())
  {
    ros::Time oldest = now - ros::Duration(kMaxPoseLag);
    const ros::Time recorded = links_.historyBegin();
    if (!recorded.isZero() && recorded < oldest) oldest = recorded;
    ROS_WARN_THROTTLE(10.0,
                      "the simulation is %.1f s behind ROS time, further than the links' poses are kept (parameter "
                      "pose_history, %g s): the links are posed at the oldest kept instant, %.1f s back, so the water "
                      "sees them move faster than they do",
                      (now - at).toSec(), opt_.pose_history, (now - oldest).toSec());
    at = oldest;
  }
  // Factor 0 ahead of ROS time: the links' newest poses (tf_delay back, so tf holds them).
  if (rtf == 0.0 && now.toSec() > opt_.tf_delay && at > now - ros::Duration(opt_.tf_delay))
    at = now - ros::Duration(opt_.tf_delay);
  return at;
}

void SolverLoop::afterStep(const StepReport& rep, double paced_rtf)
{
  ++steps_;
  sum_divergence_iterations_ += rep.divergence_iterations;
  sum_density_iterations_ += rep.density_iterations;
  sum_step_ms_ += rep.ms_total;
  if (rep.wall_guarded > 0) ++wall_guarded_steps_;
  sum_wall_guarded_ += rep.wall_guarded;
  last_report_ = rep;
  wrench_means_.add(*sim_, rep.dt);
  // Probes averaged over ~probe_window are read after every step (one counting sort of the
  // particles around the probes: 0.06 ms for 2,000 particles, README, Instruments); without a
  // window, once per frame below.
  if (probeWindowed()) probe_means_.add(rep.dt, measurements_->evaluateProbes(*sim_).probes);

  const double wall = std::chrono::duration<double>(WallClock::now() - rtf_wall0_).count();
  if (wall >= 1.0)
  {
    rtf_measured_ = (sim_->time() - rtf_sim0_) / wall;
    rtf_sim0_ = sim_->time();
    rtf_wall0_ = WallClock::now();
    rtf_first_window_ = false;
  }
  else if (rtf_first_window_ && wall > 0.0)
  {
    rtf_measured_ = (sim_->time() - rtf_sim0_) / wall;  // the window so far, until it is a second long
  }

  const double rate = publish_rate_;
  bool due;
  if (paced_rtf > 0.0)
  {
    // publish_rate frames per second of ROS time: one per paced_rtf / rate simulated seconds.
    due = sim_->time() >= next_publish_sim_ - 1e-12;
    if (due) next_publish_sim_ = std::max(next_publish_sim_ + paced_rtf / rate, sim_->time());
  }
  else
  {
    due = WallClock::now() >= next_publish_wall_;
    if (due)
      next_publish_wall_ =
          WallClock::now() + std::chrono::duration_cast<WallClock::duration>(std::chrono::duration<double>(1.0 / rate));
  }
  if (due) publishFrame(rep, paced_rtf);
}

// ------------------------------------------------------------------------------ frames
/// Copies the state into the publishers' back frame and hands it over.
void SolverLoop::publishFrame(const StepReport& rep, double paced_rtf)
{
  const auto t0 = WallClock::now();
  last_frame_sim_ = sim_->time();
  Frame& f = publishers_.back();
  f.stamp = paced_rtf > 0.0 ? rosInstant(sim_->time(), paced_rtf) : ros::Time::now();
  if (!last_frame_stamp_.isZero() && f.stamp <= last_frame_stamp_)
    f.stamp = last_frame_stamp_ + ros::Duration(0, 1000);  // 1 us on: a tf transform is never repeated
  last_frame_stamp_ = f.stamp;
  f.valid = !rep.unstable;
  f.fluid.positions = sim_->positions();
  f.fluid.velocities = sim_->velocities();
  f.fluid.pressures = sim_->pressures();
  f.fluid.densities = sim_->densities();
  // The bodies' poses, and whether one that moves has moved since the boundary cloud last went
  // out: it goes out again only then (a link that tf holds still, or a free body at rest, is posed
  // every step but sends nothing new). tf2's interpolation between two equal samples differs in
  // the last bits from step to step (3e-17 m), so a move is one beyond a millionth of a spacing
  // (the cloud's float positions do not show less).
  const double still = 1e-6 * sim_->scene().spacing;  // m
  bool any_moved = false;
  boundary_poses_.resize(sim_->numBodies());
  f.body_poses.resize(sim_->numBodies());
  f.free_bodies.bodies.clear();
  f.free_bodies.header.stamp = f.stamp;
  f.free_bodies.header.frame_id = opt_.fixed_frame;
  for (std::size_t k = 0; k < sim_->numBodies(); ++k)
  {
    const BodyInfo b = sim_->body(k);
    f.body_poses[k] = b.pose;
    if (b.free) f.free_bodies.bodies.push_back(toFreeBody(b));
    const Pose& was = boundary_poses_[k];
    any_moved = any_moved || (b.moving && ((b.pose.translation - was.translation).norm() > still ||
                                           (b.pose.rotation.coeffs() - was.rotation.coeffs()).norm() > 1e-9));
  }
  f.boundary_valid = opt_.publish_boundary && (boundary_dirty_ || any_moved);
  if (f.boundary_valid)
  {
    f.boundary = sim_->boundaryPositions();
    f.boundary_pressure = sim_->boundaryPressures();
    f.body_ranges = body_ranges_;
    boundary_dirty_ = false;
    boundary_poses_ = f.body_poses;
  }
  f.wrenches.header.stamp = f.stamp;
  f.wrenches.header.frame_id = opt_.fixed_frame;
  wrench_means_.take(*sim_, f.wrenches.wrenches);
  if (f.valid) last_wrenches_ = f.wrenches.wrenches;  // for the summary at the end
  f.regions.clear();
  f.probes.probes.clear();
  f.spill_valid = false;
  if (measurements_)
  {
    // Windowed probes were read after this step already (afterStep): their mean, not a second read.
    MeasurementReport m = measurements_->evaluate(*sim_, !probeWindowed());
    if (probeWindowed()) m.probes = probe_means_.take();
    for (const RegionMeasurement& r : m.regions)
    {
      f.regions.push_back(toRegionState(r));
      f.regions.back().header.stamp = f.stamp;
      f.regions.back().header.frame_id = opt_.fixed_frame;
    }
    f.probes.header.stamp = f.stamp;
    f.probes.header.frame_id = opt_.fixed_frame;
    for (const ProbeMeasurement& p : m.probes) f.probes.probes.push_back(toProbe(p));
    f.spill_valid = m.spill.enabled;
    if (f.spill_valid)
    {
      f.spill.header = f.probes.header;
      f.spill.below = m.spill.below;
      f.spill.particles = static_cast<std::uint32_t>(m.spill.particles);
      f.spill.volume = m.spill.volume;
      f.spill.mass = m.spill.mass;
    }
  }
  f.sinks = toSinkArray(sim_->sinkTotals(), f.stamp, opt_.fixed_frame);
  f.emitters = toEmitterArray(sim_->emitterTotals(), f.stamp, opt_.fixed_frame);
  f.stats = toSolverStats(rep, *sim_, rtf_measured_, paused_, last_status_);
  f.stats.header.stamp = f.stamp;
  f.stats.header.frame_id = opt_.fixed_frame;
  sum_copy_ms_ += msSince(t0);
  ++frames_;
  publishers_.handOver();
}

void SolverLoop::publishPausedStats()
{
  if (WallClock::now() - last_paused_stats_ < std::chrono::seconds(1)) return;
  last_paused_stats_ = WallClock::now();
  fluid_msgs::SolverStats s = toSolverStats(last_report_, *sim_, rtf_measured_, true, last_status_);
  s.header.stamp = ros::Time::now();
  s.header.frame_id = opt_.fixed_frame;
  publishers_.publishStats(s);
}

void SolverLoop::publishWaitingStats(const std::string& link)
{
  if (WallClock::now() - last_paused_stats_ < std::chrono::seconds(1)) return;
  last_paused_stats_ = WallClock::now();
  fluid_msgs::SolverStats s = toSolverStats(last_report_, *sim_, rtf_measured_, false, "waiting_for_tf: " + link);
  s.header.stamp = ros::Time::now();
  s.header.frame_id = opt_.fixed_frame;
  publishers_.publishStats(s);
}

void SolverLoop::printSummary()
{
  const double wall = std::chrono::duration<double>(WallClock::now() - run_start_).count();
  const double n = steps_ > 0 ? double(steps_) : 1.0;
  std::ostringstream os;
  os << "fluid_sim: finished at t = " << sim_->time() << " s after " << steps_ << " steps in " << wall
     << " s wall (real-time factor " << (wall > 0 ? sim_->time() / wall : 0.0) << ")\n"
     << "  status " << last_status_ << "; fluid particles " << sim_->numFluidParticles() << ", removed "
     << sim_->removedTotal() << "\n"
     << "  per step: " << sum_step_ms_ / n << " ms, divergence iterations " << sum_divergence_iterations_ / n
     << ", density iterations " << sum_density_iterations_ / n << "; last density error " << last_report_.density_error
     << "\n"
     << "  publishing: " << frames_ << " frames, copying a frame out of the solver took "
     << (frames_ ? sum_copy_ms_ / double(frames_) : 0.0) << " ms ("
     << (frames_ ? 100.0 * (sum_copy_ms_ / frames_) / (sum_step_ms_ / n) : 0.0) << " % of a step)\n";
  if (sum_wall_guarded_ > 0)
    os << "  wall guard (solver.wall_guard): held " << sum_wall_guarded_ << " particle steps short of a wall in "
       << wall_guarded_steps_ << " of " << steps_ << " steps (the pressure alone let that water run into a wall)\n";
  // The wrenches of the last published message, each a mean over ~wrench_window, as the topics
  // gave them: one step's force jitters by tens of per cent (it read 0.94 N where the messages
  // and the runner's mean read 0.82). Before any message, the last step's.
  const bool windowed = last_wrenches_.size() == sim_->numBodies();
  if (steps_ > 0 && windowed)
    os << "  wrenches (the last message's, each the mean over ~wrench_window = " << opt_.wrench_window << " s):\n";
  else if (steps_ > 0)
    os << "  wrenches (the last step's):\n";
  for (std::size_t k = 0; k < sim_->numBodies(); ++k)
  {
    const BodyInfo b = sim_->body(k);
    Vec3d force = b.force_body, torque = b.torque_body;
    if (windowed)
    {
      const geometry_msgs::Wrench& w = last_wrenches_[k].wrench;
      force = Vec3d(w.force.x, w.force.y, w.force.z);
      torque = Vec3d(w.torque.x, w.torque.y, w.torque.z);
    }
    os << "  " << b.name << ": force [" << force.x() << ", " << force.y() << ", " << force.z() << "] N, torque ["
       << torque.x() << ", " << torque.y() << ", " << torque.z() << "] N m (link frame), " << b.contact_particles
       << " contact particles\n";
  }
  std::fputs(os.str().c_str(), stdout);
  std::fflush(stdout);
}

}  // namespace ros_bridge
}  // namespace fluid_sim
