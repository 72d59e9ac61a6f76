#pragma once
// Emitters (scene key `emitters`, docs/method.md, Emitters): nozzles that add water during the run.
// A nozzle is a lattice of points one spacing apart over its opening; each time the water it
// released has travelled one spacing at the exit speed, it releases the next layer, so the stream
// leaves at rest density (the lattice of the initial fill: one particle per spacing^3) and the
// volume released over a time T is n s^2 v T, the flow rate times T, to within one layer.

#include <cstddef>
#include <string>
#include <vector>

#include "fluid_sim/core/scene_config.h"
#include "fluid_sim/core/types.h"

namespace fluid_sim
{
class BodySet;
struct FluidParticles;

/// What an emitter has released since t = 0.
struct EmitterTotal
{
  std::string name;
  std::size_t particles = 0;    // released
  std::size_t blocked = 0;      // lattice points left out: too close to water or a wall, in a solid, outside the domain
  double volume = 0.0;          // m^3, particles times spacing^3 (the volume each stands for)
  double mass = 0.0;            // kg
  double flow_rate = 0.0;       // m^3/s, the nozzle's: points x spacing^2 x exit speed
  double speed = 0.0;           // m/s, exit speed
  std::size_t points = 0;       // lattice points over the opening
  bool budget_reached = false;  // stopped at max_particles or the scene's max_fluid_particles
};

class Emitters
{
public:
  /// Lays out each nozzle's lattice and resolves its body. Throws ConfigError naming
  /// emitters[i].body for a body that is not in `bodies`, emitters[i].speed or .flow_rate for an
  /// exit speed above stability.max_cfl spacings per shortest time step, and emitters[i].pose.xyz
  /// for a nozzle fixed in the world outside the domain.
  Emitters(const SceneConfig& scene, const BodySet& bodies);

  /// Particles the emitters will add at most where that is known beforehand (a duration or a
  /// max_particles): the caller reserves storage for them once.
  std::size_t expectedParticles() const;

  /// The water released over the step from t (s) to t + dt: layers whose time came in it, at the
  /// nozzles' current poses (attached ones at their body's pose), appended to `fluid` at rest
  /// density with zero pressure. Returns how many particles were added.
  std::size_t emit(double t, double dt, FluidParticles& fluid, const BodySet& bodies);

  /// Poses an externally posed emitter (nozzle frame -> world).
  void setPose(std::size_t index, const Pose& pose);

  /// The nozzle frame -> world of emitter `index` now.
  Pose worldPose(std::size_t index, const BodySet& bodies) const;

  const std::vector<EmitterTotal>& totals() const
  {
    return totals_;
  }
  bool empty() const
  {
    return nozzles_.empty();
  }

private:
  struct Nozzle
  {
    EmitterConfig config;
    std::vector<Vec3d> points;  // m, the opening's lattice in the nozzle frame (z = 0)
    long body = -1;             // index in the BodySet, -1 = world
    double speed = 0.0;         // m/s
    double passed = 0.0;        // m of stream that has passed the opening while it was open
    double moved = 0.0;         // m the stream has moved since the nozzle opened (on after it closed)
    std::size_t layers = 0;     // whole layers released
    bool done = false;          // closed and everything released
    std::size_t budget = 0;     // most particles to release (0: the scene's budget only)
  };

  double spacing_;     // m
  Real rest_density_;  // kg/m^3
  std::size_t max_fluid_particles_;
  AxisBox domain_;  // the scene's domain (m): points outside it are left out
  std::vector<Nozzle> nozzles_;
  std::vector<EmitterTotal> totals_;
};

}  // namespace fluid_sim
