#pragma once
// Wall-clock timing of the step's phases for the StepReport (ms), kept out of the physics code.

#include <chrono>

namespace fluid_sim
{
/// Adds the milliseconds from its construction to its destruction to `target`.
class PhaseTimer
{
public:
  explicit PhaseTimer(double& target) : target_(target), start_(Clock::now()) {}
  ~PhaseTimer()
  {
    target_ += std::chrono::duration<double, std::milli>(Clock::now() - start_).count();
  }
  PhaseTimer(const PhaseTimer&) = delete;
  PhaseTimer& operator=(const PhaseTimer&) = delete;

private:
  using Clock = std::chrono::steady_clock;
  double& target_;  // ms
  Clock::time_point start_;
};

}  // namespace fluid_sim
