#include "fluid_sim/io/simulation_output.h"

#include "fluid_sim/io/ply_writer.h"

namespace fluid_sim
{
namespace io
{
void writePly(const std::string& path, const Simulation& sim)
{
  writePly(path, sim.positions(), sim.velocities(), sim.pressures(), sim.densities());
}

std::vector<std::string> bodyNames(const Simulation& sim)
{
  std::vector<std::string> names;
  for (std::size_t i = 0; i < sim.numBodies(); ++i) names.push_back(sim.body(i).name);
  return names;
}

std::vector<Wrench> bodyWrenches(const Simulation& sim)
{
  std::vector<Wrench> wrenches;
  for (std::size_t i = 0; i < sim.numBodies(); ++i)
  {
    const BodyInfo body = sim.body(i);
    wrenches.push_back({body.force, body.torque});
  }
  return wrenches;
}

std::vector<BodyInfo> bodyInfos(const Simulation& sim)
{
  std::vector<BodyInfo> bodies;
  for (std::size_t i = 0; i < sim.numBodies(); ++i) bodies.push_back(sim.body(i));
  return bodies;
}

bool hasFreeBodies(const Simulation& sim)
{
  for (std::size_t i = 0; i < sim.numBodies(); ++i)
    if (sim.body(i).free) return true;
  return false;
}

RunSummary summarize(const Simulation& sim, const RunStatistics& stats)
{
  RunSummary s;
  s.scene = sim.scene().source;
  s.method = toString(sim.scene().solver.boundary_pressure);
  s.spacing = sim.scene().spacing;
  s.initial_fluid_particles = sim.initialFluidParticles();
  s.final_fluid_particles = sim.numFluidParticles();
  s.removed_at_start = sim.removedAtStart();
  s.removed_total = sim.removedTotal();
  s.boundary_particles = sim.boundaryPositions().size();
  s.fill = sim.fillReport();
  stats.fill(s);
  for (std::size_t i = 0; i < sim.numBodies(); ++i)
  {
    const BodyInfo b = sim.body(i);
    if (b.free)
      s.free_bodies.push_back({b.name, b.center_of_mass, b.pose.rotation, b.com_velocity, b.angular_velocity, b.mass});
  }
  s.sinks = sim.sinkTotals();
  s.emitters = sim.emitterTotals();
  return s;
}

}  // namespace io
}  // namespace fluid_sim
