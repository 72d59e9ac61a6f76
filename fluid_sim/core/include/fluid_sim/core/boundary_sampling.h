#pragma once
// Sampling of boundary surfaces into one layer of boundary particles (Akinci et al. 2012), in the
// body frame, deterministic, and the geometric inside tests used to clear fluid from solids.

#include <vector>

#include "fluid_sim/core/scene_config.h"
#include "fluid_sim/core/types.h"

namespace fluid_sim
{
/// Points on the surface of an axis-aligned box, a lattice with spacing <= s per axis (m).
std::vector<Vec3d> sampleBoxSurface(const AxisBox& box, double s);
/// Points on a sphere (Fibonacci lattice, about one point per (sqrt(3)/2) s^2 of area).
std::vector<Vec3d> sampleSphereSurface(const Vec3d& center, double radius, double s);
/// Points on a closed cylinder: rings on the side, concentric rings on both caps.
std::vector<Vec3d> sampleCylinderSurface(const CylinderShape& cyl, double s);
/// Points on a triangle mesh, evenly: no two closer than 0.66 s and no point of the surface
/// farther than 0.74 s from a sample. Sharp edges (borders, creases over 30 degrees) are divided
/// evenly into pieces <= s, corners included, and every planar patch carries a lattice of spacing
/// <= s aligned with its border (a box face gets the box primitive's lattice); what is left
/// (seams, slanted borders, curved surfaces) is filled. Deterministic; time and memory about
/// linear in the area, also for large meshes and sliver triangles. Each sample moves by `offset`
/// (m) along its triangle's normal (negative = against the normal). Degenerate (zero-area)
/// triangles are skipped and counted.
std::vector<Vec3d> sampleMeshSurface(const TriangleMesh& mesh, double s, double offset,
                                     std::size_t* degenerate_triangles = nullptr);

/// The mesh with every face moved by `offset` (m) along its normal and the vertices mitred where
/// faces meet (a box grows into the box `offset` larger on every side, corners included), so that
/// a layer sampled on it has no gap along edges. Negative = against the normals. Each vertex moves
/// at most 3 |offset|. Used by sampleBoundary() for closed meshes.
TriangleMesh offsetMesh(const TriangleMesh& mesh, double offset);

/// Surface area of a triangle mesh, m^2.
double meshArea(const TriangleMesh& mesh);

/// How many boundary particles sampleBoundary(b, s, fluid_spacing) makes, computed from the
/// shape's size without sampling: exact for the primitives; for meshes 2 per s^2 of surface, above
/// what the sampler makes on typical meshes (1.0-1.8). validate() compares it with
/// max_boundary_particles.
double estimateBoundaryParticles(const BoundaryConfig& b, double s, double fluid_spacing);

/// The boundary layer for one scene boundary, in its body frame: the surface moved half a spacing
/// into the solid (or out of a container) so that the water meets the geometric surface
/// (METHOD.md, boundary particles). `s` is the sample spacing (m), `fluid_spacing` the scene's.
std::vector<Vec3d> sampleBoundary(const BoundaryConfig& b, double s, double fluid_spacing);

/// True if body-frame point p lies inside the body's geometric solid (for a closed shape).
/// Open meshes have no inside and return false. A closed mesh counts a point inside where its
/// winding number is positive (overlapping closed parts act as their union); with
/// mesh.inside_index set (buildInsideIndex()) only the triangles near the test ray are visited.
bool insideShape(const BoundaryConfig& b, const Vec3d& p);

/// Akinci volumes V_b = gamma / sum_b' W(x_b - x_b') over the given points (self included); m^3.
/// Akinci et al. use gamma = 1; see flatLayerVolumeFactor() for the value the simulation uses.
std::vector<Real> boundaryVolumes(const std::vector<Vec3d>& points, double support, double gamma = 1.0);

/// The volume factor gamma that gives a flat boundary layer sampled at the fluid spacing the
/// volume s^3 of the one fluid layer it replaces. With gamma = 1 (plain Akinci) a single layer
/// counts 1/0.70 = 1.43 times (cubic spline, h = 2 s): fluid next to a flat wall starts 6 %
/// over rest density, in a corner 15 %, which the first density solve cannot remove
/// (engineering choice, tested in boundary_sampling_test).
double flatLayerVolumeFactor(double spacing, double support);

/// Reorders points along cells of size `cell` (x fastest) for memory locality.
void sortByCell(std::vector<Vec3d>& points, double cell);

}  // namespace fluid_sim
