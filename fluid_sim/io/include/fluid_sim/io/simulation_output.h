#pragma once
// The writers applied to a running Simulation. Kept apart from the writers themselves, which
// take plain data, so that they can be used (and tested) without a Simulation.

#include <string>
#include <vector>

#include "fluid_sim/core/simulation.h"
#include "fluid_sim/io/run_summary.h"

namespace fluid_sim
{
namespace io
{
/// Writes the fluid particles of `sim` as one PLY frame (see writePly()).
void writePly(const std::string& path, const Simulation& sim);

/// Names of the bodies, in body index order.
std::vector<std::string> bodyNames(const Simulation& sim);

/// The wrench the fluid exerted on every body in the last step: world frame, N and N m about the
/// body origin, in body index order.
std::vector<Wrench> bodyWrenches(const Simulation& sim);

/// Every body's state (Simulation::body()), in body index order.
std::vector<BodyInfo> bodyInfos(const Simulation& sim);

/// Whether any body of `sim` is free (BodyInfo::free).
bool hasFreeBodies(const Simulation& sim);

/// A summary of the run so far: scene facts and particle counts from `sim`, step figures and body
/// wrenches from `stats`, the free bodies' current state from `sim`. The caller sets threads,
/// overrides, wall_time, status and reason.
RunSummary summarize(const Simulation& sim, const RunStatistics& stats);

}  // namespace io
}  // namespace fluid_sim
