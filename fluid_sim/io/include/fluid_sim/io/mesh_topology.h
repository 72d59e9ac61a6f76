#pragma once
// Topology checks on triangle meshes read by io (inline scene meshes now, mesh files and URDF
// collision meshes later): whether a mesh is closed, and orienting a closed one outward, as
// core's boundary sampling assumes (BoundaryConfig::mesh_closed).

#include "fluid_sim/core/scene_config.h"

namespace fluid_sim
{
namespace io
{
/// True if every edge is shared by exactly two triangles that run along it in opposite directions:
/// a closed, consistently oriented surface. Open meshes (a cup, a paddle) and inconsistently
/// wound ones are not closed.
bool isClosedMesh(const TriangleMesh& mesh);

/// Volume enclosed by a closed mesh, m^3 (divergence theorem); negative if its normals point inward.
double signedVolume(const TriangleMesh& mesh);

/// Makes the normals of a closed mesh point outward (flips every triangle if they point inward);
/// an open mesh is left as it is. Returns isClosedMesh(mesh).
bool orientOutward(TriangleMesh& mesh);

}  // namespace io
}  // namespace fluid_sim
