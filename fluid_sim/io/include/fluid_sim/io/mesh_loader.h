#pragma once
// Mesh files (STL ASCII and binary, OBJ, COLLADA, PLY and the other formats assimp reads) into one
// core TriangleMesh, and triangle meshes of the URDF primitives (box, cylinder, sphere).

#include <cstddef>
#include <string>
#include <vector>

#include "fluid_sim/core/scene_config.h"
#include "fluid_sim/core/types.h"

namespace fluid_sim
{
namespace io
{
/// A mesh read from a file, ready for a BoundaryConfig.
struct MeshFile
{
  TriangleMesh mesh;                     // m, in the file's frame; outward-oriented if closed; inside index built
  bool closed = false;                   // isClosedMesh(mesh)
  std::size_t border_edges = 0;          // borderEdges(mesh): 0 for a closed mesh
  std::size_t degenerate_triangles = 0;  // zero area: kept for the topology, skipped when sampling
};

/// Reads every triangle of a mesh file into one mesh in the file's frame, each vertex multiplied
/// component-wise by `scale` (unit-less; a negative product mirrors and re-winds the triangles).
/// Every mesh of the file becomes part of the one surface, placed by its node transforms; COLLADA's
/// <unit meter=...> is applied, its <up_axis> is not (ROS convention: a mesh is used as written,
/// z up). Vertices at the same position (within 1e-7 of the mesh's size) are joined, also across
/// the file's meshes and where STL repeats every corner per face, so that closedness can be decided;
/// triangles that then repeat a vertex are dropped and counted as degenerate. Throws
/// ConfigError(path, ...) for a missing or unreadable file, an unknown format, a file that does not
/// parse, a COLLADA file whose counts or numbers do not match its data (checkColladaText(), before
/// assimp reads it), a file without triangles, or a NaN or infinite vertex.
MeshFile readMeshFile(const std::string& path, const Vec3d& scale = Vec3d::Ones());

/// Surface of a box with edge lengths `size` (m) centred at the origin: 8 vertices, 12 triangles,
/// outward.
TriangleMesh boxMesh(const Vec3d& size);

/// Closed cylinder of `radius` and `length` (m) about the z axis, centred at the origin, outward,
/// with enough side facets that no point of the true surface is farther than `max_error` (m)
/// from the facets.
TriangleMesh cylinderMesh(double radius, double length, double max_error);

/// Sphere of `radius` (m) about the origin, outward, facets within `max_error` (m) of the sphere.
TriangleMesh sphereMesh(double radius, double max_error);

/// Appends `part`, moved by `pose`, to `mesh` (vertex indices offset; nothing is joined).
void appendMesh(TriangleMesh& mesh, const TriangleMesh& part, const Pose& pose = Pose());

/// Notes (not errors) about a surface, each starting with `what`: degenerate triangles skipped, and
/// a surface that is not closed (sampled as a thin shell, nothing removed from inside it).
std::vector<std::string> surfaceNotes(const std::string& what, bool closed, std::size_t border_edges,
                                      std::size_t degenerate_triangles);

}  // namespace io
}  // namespace fluid_sim
