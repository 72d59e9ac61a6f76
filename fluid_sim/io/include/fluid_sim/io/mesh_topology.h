#pragma once
// Topology of the triangle meshes io reads (inline scene meshes, mesh files, URDF collision
// geometry): whether a mesh is closed, its border edges, its signed volume, and orienting a closed
// mesh outward, as core's boundary sampling assumes (BoundaryConfig::mesh_closed).

#include <cstddef>

#include "fluid_sim/core/scene_config.h"

namespace fluid_sim
{
namespace io
{
/// True if every edge is shared by exactly two triangles that run along it in opposite directions:
/// a closed, consistently oriented surface. Open meshes (a cup, a paddle) and inconsistently
/// wound ones are not closed.
bool isClosedMesh(const TriangleMesh& mesh);

/// Number of directed edges without an opposite twin: 0 for a closed, consistently wound mesh,
/// the rim of an open one (a cup's brim) otherwise.
std::size_t borderEdges(const TriangleMesh& mesh);

/// Volume enclosed by a closed mesh, m^3 (divergence theorem); negative if its normals point inward.
double signedVolume(const TriangleMesh& mesh);

/// Makes the normals of a closed mesh point outward (flips every triangle if they point inward);
/// an open mesh is left as it is. Returns isClosedMesh(mesh).
bool orientOutward(TriangleMesh& mesh);

}  // namespace io
}  // namespace fluid_sim
