#pragma once
// Reading a particle frame back: the runner's own PLY (ply_writer.h), for starting a run from a
// saved state (scene key fluid[i].particles). Strict, with messages that say what is wrong.

#include <string>
#include <vector>

#include "fluid_sim/core/types.h"

namespace fluid_sim
{
namespace io
{
/// The particles of one frame, in the file's order.
struct PlyFrame
{
  std::vector<Vec3d> positions;   // m
  std::vector<Vec3d> velocities;  // m/s, one per position
};

/// Reads the positions (properties x y z, m) and velocities (vx vy vz, m/s) of a particle frame:
/// a PLY file, `format binary_little_endian 1.0` (as writePly() writes it) or `format ascii 1.0`,
/// with exactly one element, `vertex`, of scalar properties. The six properties are found by
/// name in any order and must be float (float32) or double (float64); other scalar properties
/// (writePly()'s pressure and density) are skipped, and so are comment and obj_info lines.
/// Throws ConfigError(path, message) for a missing or unreadable file, a header that is not such
/// a PLY (naming the header line), a missing or non-float property, data shorter or longer than
/// the vertex count announces, an ascii value that is not a number, or a non-finite position or
/// velocity (naming the vertex).
PlyFrame readPlyFrame(const std::string& path);

/// Checks the header of a PLY mesh (the content `data` of the file at `path`) before assimp reads
/// it: assimp 5.2 loops without end on a header it cannot finish (fuzz_mesh_ply: a header whose
/// end_header is misspelt ran for minutes, seeking in the file). Requires 'ply' on the first line,
/// one `format ascii|binary_little_endian|binary_big_endian 1.0`, `element <name> <count>` lines,
/// `property <type> <name>` or `property list <count type> <type> <name>` lines with PLY types,
/// comment and obj_info lines, and an `end_header` line; throws ConfigError(path, message naming
/// the header line) otherwise. The data after the header is left to assimp.
void checkPlyMeshHeader(const std::string& path, const std::string& data);

}  // namespace io
}  // namespace fluid_sim
