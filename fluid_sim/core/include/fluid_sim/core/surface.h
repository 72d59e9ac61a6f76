#pragma once
// The free surface of the water as a closed triangle mesh (docs/method.md, Free-surface mesh,
// Eqs. A28-A30): a sphere around every fluid particle, their union as a signed distance field on a
// sparse voxel grid, smoothed, and its zero level meshed. Done by OpenVDB, whose headers stay in
// surface.cpp (they are slow to compile and none of the core's dependants needs them). ROS-free,
// no file I/O: the runner writes the mesh as OBJ (io/obj_writer.h), the node publishes it as a
// Marker.

#include <array>
#include <cstddef>
#include <vector>

#include "fluid_sim/core/types.h"

namespace fluid_sim
{
/// How the surface is reconstructed. Lengths are in spacings s (the scene's `spacing`), so that
/// one set of values fits every resolution; the defaults were chosen by measurement
/// (docs/method.md, Free-surface mesh: the volume and height errors and the cost of each choice).
struct SurfaceOptions
{
  /// Radius r of the sphere around each particle, in s (Eq. A28): after the smoothing the surface
  /// lies about where the distance to the nearest particle is r. 0.64 s is that distance averaged
  /// over a flat lattice face s/2 beyond its particles (where their cells, s^3 each, end); the
  /// smoothing (Eq. A29) draws a face inward by a little more, which 0.78 makes up for at
  /// dx = s/3 (0.72 at dx = s/4): a lattice block's top face within 0.06 s of its height.
  double particle_radius = 0.78;
  /// Edge dx of a voxel, in s. The smoothing is a few voxels wide, so dx sets how round edges and
  /// drops come out and, with particle_radius, where a face lies; the triangle count grows as
  /// 1/h^2, the cost as 1/h^3. s/3: half the cost and triangles of s/4, faces within 0.06 s
  /// instead of 0.03 s wherever they fall between the voxels.
  double voxel_size = 1.0 / 3.0;
  /// Passes of OpenVDB's Gaussian filter over the distance field (Eq. A29), each sigma = 1.63
  /// voxels (0.54 s at dx = s/3): they take out the bumps of the union of spheres and the gaps
  /// between them inside. 0 = none (a bumpy surface with hollows inside the water); each further
  /// pass draws the faces inward and rounds edges more (a larger radius must make up for it).
  int smoothing_passes = 1;
  /// Radius r_d of the sphere every particle keeps whatever the smoothing, in s (Eq. A29b): a lone
  /// particle or a pair would otherwise vanish (the smoothing is wider than they are). Below s/2,
  /// so that it stays inside the smoothed face of a block of water. 0 = none.
  double drop_radius = 0.45;
  /// OpenVDB's adaptivity in [0, 1]: 0 = a uniform mesh (two triangles per voxel face the surface
  /// crosses); larger values merge flat parts into fewer, larger polygons.
  double adaptivity = 0.0;
  /// Most voxels the bounding box of the particles (widened by the spheres and the narrow band)
  /// may hold; more is refused with a ConfigError naming the count. The grid is sparse (memory
  /// goes with the voxels near particles), but a particle far from the rest or a voxel far
  /// smaller than the water would make a box whose coordinates overflow OpenVDB's 32-bit indices
  /// or whose surface is unbounded. 4e9 is 1,587 voxels a side: the default domain (3 m) at
  /// dx = 1.9 mm, a spacing of 5.7 mm.
  double max_voxels = 4.0e9;
};

/// A triangle mesh: vertices (m, world) and triangles as indices into them, counter-clockwise
/// seen from outside the water (right-handed normals point out of it). Closed (every edge
/// belongs to two triangles, which run along it in opposite directions) wherever the water
/// surface is inside the particles' bounding box.
struct SurfaceMesh
{
  std::vector<Vec3> vertices;  // m
  std::vector<std::array<Index, 3>> triangles;
  std::size_t particles = 0;          // particles the mesh was made from
  std::size_t skipped_particles = 0;  // left out: a non-finite position (NaN, infinite)
  double voxel_size = 0.0;            // m, the grid's dx
  double particle_radius = 0.0;       // m, the spheres' r
  double ms = 0.0;                    // wall time of the reconstruction

  bool empty() const
  {
    return triangles.empty();
  }
};

/// The free surface of the water whose particles are at `positions` (m), on the lattice spacing
/// `spacing` (m, > 0). Particles with a non-finite position are left out (counted in
/// skipped_particles); no particle (or none left) gives an empty mesh. Throws ConfigError
/// (key "surface") for a spacing or options out of range and for a bounding box beyond
/// options.max_voxels, naming the values. Uses TBB's threads as the caller's arena allows.
SurfaceMesh reconstructSurface(const std::vector<Vec3>& positions, double spacing,
                               const SurfaceOptions& options = SurfaceOptions());

/// The volume (m^3) a closed, outward-oriented mesh encloses (divergence theorem: the sum over
/// triangles of a . (b x c) / 6); negative if it is oriented inward.
double enclosedVolume(const SurfaceMesh& mesh);

}  // namespace fluid_sim
