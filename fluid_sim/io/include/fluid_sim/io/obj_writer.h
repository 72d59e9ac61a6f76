#pragma once
// The free-surface mesh (core surface.h) as a Wavefront OBJ file (readable by ParaView, Blender,
// MeshLab): the runner's surface/NNNNNN.obj, one beside each PLY frame frames/NNNNNN.ply.

#include <string>

#include "fluid_sim/core/surface.h"

namespace fluid_sim
{
namespace io
{
/// Writes `mesh`: a comment line, one `v x y z` line per vertex (m, as many digits as Real needs
/// to be read back exactly), one `f a b c` line per triangle (1-based vertex numbers, counter-
/// clockwise seen from outside the water, as the mesh has them). An empty mesh gives a file with
/// the comment only. Written to "<path>.tmp" and renamed, so a reader never sees a half-written
/// file; throws std::runtime_error naming the path if it cannot be written.
void writeObj(const std::string& path, const SurfaceMesh& mesh);

/// "000042.obj": the surface of frame 42 (frameFileName(42) is "000042.ply").
std::string surfaceFileName(std::size_t frame_index);

}  // namespace io
}  // namespace fluid_sim
