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
  return s;
}

}  // namespace io
}  // namespace fluid_sim
