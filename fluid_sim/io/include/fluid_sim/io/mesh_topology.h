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
/// The topology below sees the mesh with vertices closer than 1e-5 of its bounding box's diagonal
/// joined, then vertices on the rim of a hole within 1e-4 of it joined with other rim vertices
/// no edge joins them to (a seam between separately exported faces), and zero-area triangles left
/// out (CAD slivers), the geometry unchanged.

/// True if every edge is run by its triangles as often one way as the other: a closed,
/// consistently oriented surface (two triangles per edge, or more where closed parts meet at an
/// edge). Open meshes (a cup, a paddle) and inconsistently wound ones are not closed.
bool isClosedMesh(const TriangleMesh& mesh);

/// Number of edges of one triangle only: 0 for a closed mesh, the rim of an open one (a cup's
/// brim) otherwise.
std::size_t borderEdges(const TriangleMesh& mesh);

/// Whether the triangle (a, b, c) (m) has zero area: twice its area at most 1e-12 of its longest
/// edge squared (collinear corners; a sliver a CAD export leaves along an edge).
bool zeroArea(const Vec3d& a, const Vec3d& b, const Vec3d& c);

/// Volume enclosed by a closed mesh, m^3 (divergence theorem); negative if its normals point inward.
double signedVolume(const TriangleMesh& mesh);

/// Winds the triangles of each connected part consistently where every edge has two triangles
/// (a face flipped against its neighbours is turned), then, for a closed mesh, makes each part's
/// normals point outward (its enclosed volume positive). Returns isClosedMesh(mesh).
bool orientOutward(TriangleMesh& mesh);

}  // namespace io
}  // namespace fluid_sim
