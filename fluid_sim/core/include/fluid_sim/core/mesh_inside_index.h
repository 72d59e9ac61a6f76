#pragma once
// Point-in-solid queries on a closed triangle mesh, fast enough to clear the fluid lattice of a
// scene with large meshes: a ray along +x (slightly skewed, so it rarely grazes an edge) is tested
// only against the triangles whose (y, z) footprint its start lies in. The answer is the winding
// number, so overlapping closed parts of one body (a URDF link made of several collision elements)
// count as their union, and a hollow part (an outer surface and an inward-facing inner one) as the
// material between them.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "fluid_sim/core/scene_config.h"
#include "fluid_sim/core/types.h"

namespace fluid_sim
{
class MeshInsideIndex
{
public:
  /// Bins the triangles of `mesh` (which must have valid indices) over the (y, z) plane.
  explicit MeshInsideIndex(const TriangleMesh& mesh);

  /// True if the index was built for a mesh with these vertex and triangle counts (a cheap guard
  /// against an index left over from before the mesh was edited).
  bool matches(const TriangleMesh& mesh) const;

  /// Winding number of the mesh around body-frame point p (m): +1 inside an outward-oriented
  /// closed surface, 0 outside, 2 where two such parts overlap.
  int winding(const TriangleMesh& mesh, const Vec3d& p) const;

private:
  std::size_t num_vertices_ = 0;
  std::size_t num_triangles_ = 0;
  Vec3d lo_ = Vec3d::Zero();              // m, bounding box
  Vec3d hi_ = Vec3d::Zero();              // m
  int ny_ = 1, nz_ = 1;                   // bins over y and z
  double bin_y_ = 1.0;                    // m
  double bin_z_ = 1.0;                    // m
  std::vector<std::uint32_t> start_;      // CSR row starts, ny_ * nz_ + 1
  std::vector<std::uint32_t> triangles_;  // triangle indices per bin
};

/// Winding number of `mesh` around p by testing every triangle (no index); see MeshInsideIndex.
int windingNumber(const TriangleMesh& mesh, const Vec3d& p);

/// Builds mesh.inside_index so that insideShape() on this mesh is fast. Call again after editing
/// the mesh (a stale index whose counts no longer match is ignored).
void buildInsideIndex(TriangleMesh& mesh);

}  // namespace fluid_sim
