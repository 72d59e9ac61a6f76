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
/// Points on a triangle mesh: a fine barycentric lattice per triangle thinned greedily (in a fixed
/// order) to a minimum distance of `min_distance_factor` * s, so no point of the surface is
/// farther than about 0.75 s from a sample. Each sample moves by `offset` (m) along its
/// triangle's normal (negative = against the normal). Degenerate triangles are skipped and counted.
std::vector<Vec3d> sampleMeshSurface(const TriangleMesh& mesh, double s, double offset,
                                     std::size_t* degenerate_triangles = nullptr);

/// The boundary layer for one scene boundary, in its body frame: the surface moved half a spacing
/// into the solid (or out of a container) so that the water meets the geometric surface
/// (METHOD.md, boundary particles). `s` is the sample spacing (m), `fluid_spacing` the scene's.
std::vector<Vec3d> sampleBoundary(const BoundaryConfig& b, double s, double fluid_spacing);

/// True if body-frame point p lies inside the body's geometric solid (for a closed shape).
/// Open meshes have no inside and return false.
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
