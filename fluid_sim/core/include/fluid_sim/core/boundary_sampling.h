#pragma once
// Boundary particles (Akinci et al. 2012): sampling a boundary's surface into one layer, in the body
// frame and deterministically; the layer's particle volumes; and the geometric inside test used to
// clear fluid from solids. Equation numbers refer to docs/method.md.
//   boundary_sampling.cpp   one scene boundary: sampleBoundary, estimateBoundaryParticles, insideShape
//   primitive_sampling.cpp  boxes, spheres, cylinders
//   mesh_sampling.cpp       triangle meshes: edges and corners, face lattices, the fill; meshArea
//   mesh_offset.cpp         the mitred offset surface of a mesh
//   boundary_volume.cpp     V_b (Eq. A3) and the flat-layer factor gamma

#include <cstddef>
#include <string>
#include <vector>

#include "fluid_sim/core/scene_config.h"
#include "fluid_sim/core/types.h"

namespace fluid_sim
{
// ---------------------------------------------------------------------------- one boundary

/// The boundary layer for one scene boundary, in its body frame (m): the surface moved half a
/// fluid spacing into the solid (or out of a container) so that the water meets the geometric
/// surface (docs/method_notes.md, boundary particles), sorted by cells of 2 fluid spacings. `s`
/// is the sample spacing (m), `fluid_spacing` the scene's (m).
std::vector<Vec3d> sampleBoundary(const BoundaryConfig& b, double s, double fluid_spacing);

/// How many boundary particles sampleBoundary(b, s, fluid_spacing) makes, computed from the
/// shape's size without sampling: exact for the primitives; for meshes 2 per s^2 of surface, above
/// what the sampler makes on typical meshes (1.0-1.8). validate() compares it with
/// max_boundary_particles.
double estimateBoundaryParticles(const BoundaryConfig& b, double s, double fluid_spacing);

/// An estimate for messages: the whole number ("12345") up to 10^15, beyond that (and for inf or
/// NaN, which no integer type holds) as a stream prints it ("1e+30", "inf").
std::string estimateText(double estimate);

/// True if body-frame point p (m) lies inside the body's geometric solid (for a closed shape).
/// Open meshes have no inside and return false. A closed mesh counts a point inside where its
/// winding number is positive (overlapping closed parts act as their union); with
/// mesh.inside_index set (buildInsideIndex()) only the triangles near the test ray are visited.
bool insideShape(const BoundaryConfig& b, const Vec3d& p);

// ------------------------------------------------------------------------------ primitives

/// Points on the surface of an axis-aligned box, a lattice with spacing <= s per axis (m).
std::vector<Vec3d> sampleBoxSurface(const AxisBox& box, double s);
/// Points on a sphere (Fibonacci lattice, about one point per (sqrt(3)/2) s^2 of area).
std::vector<Vec3d> sampleSphereSurface(const Vec3d& center, double radius, double s);
/// Points on a closed cylinder: rings on the side, concentric rings on both caps.
std::vector<Vec3d> sampleCylinderSurface(const CylinderShape& cyl, double s);

// ---------------------------------------------------------------------------------- meshes

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

// ------------------------------------------------------------------------------- volumes

/// Volumes V_b = gamma / sum_b' W(x_b - x_b') over the given points (m; self included), m^3
/// (Eq. A3). Akinci et al. use gamma = 1; see flatLayerVolumeFactor() for the value the simulation
/// uses. `support` is the kernel support (m).
std::vector<Real> boundaryVolumes(const std::vector<Vec3d>& points, double support, double gamma = 1.0);

/// The volume factor gamma that gives a flat boundary layer sampled at the fluid spacing (m) the
/// volume s^3 of the one fluid layer it replaces (Eq. A3). With gamma = 1 (plain Akinci) a single
/// layer counts 1/0.70 = 1.43 times (cubic spline, Eq. A18, support 2 s): fluid next to a flat wall
/// starts 6 % over rest density, in a corner 15 %, which the first density solve cannot remove
/// (engineering choice, docs/method_notes.md).
double flatLayerVolumeFactor(double spacing, double support);

/// sum_b V_b W over a flat layer on a square lattice of spacing `spacing` (m), volume s^3 each, at
/// `distance` (m) from its plane: the part of a fluid particle's kernel (support m) the layer
/// fills (unit-less; 0.70 on the layer, 0.49 half a spacing off it). The wall guard's measure
/// (Eq. A31); on the plane, gamma.
double flatLayerFill(double spacing, double support, double distance);

}  // namespace fluid_sim
