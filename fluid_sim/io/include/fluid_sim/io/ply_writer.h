#pragma once
// Particle frames as binary little-endian PLY (readable by ParaView, Blender, CloudCompare):
// one `vertex` element with float properties x y z vx vy vz pressure density. ply_reader.h reads
// them back to start a run from a saved state.

#include <string>
#include <vector>

#include "fluid_sim/core/types.h"

namespace fluid_sim
{
namespace io
{
/// Writes one frame: positions (m), velocities (m/s), pressures (Pa) and densities (kg/m^3), one
/// entry per particle, all of the same length (else std::invalid_argument). Written to
/// "<path>.tmp" and renamed, so a reader never sees a half-written frame. Throws
/// std::runtime_error naming the path if it cannot be written.
void writePly(const std::string& path, const std::vector<Vec3>& positions, const std::vector<Vec3>& velocities,
              const std::vector<Real>& pressures, const std::vector<Real>& densities);

/// "000042.ply": frame file names sort in time order.
std::string frameFileName(std::size_t frame_index);

}  // namespace io
}  // namespace fluid_sim
