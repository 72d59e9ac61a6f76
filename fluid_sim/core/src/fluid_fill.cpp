// The initial fluid: lattices and explicit particles (see fluid_fill.h).

#include "fluid_sim/core/fluid_fill.h"

#include <cmath>
#include <memory>

#include "fluid_sim/core/boundary_sampling.h"
#include "fluid_sim/core/neighbor_search.h"
#include "fluid_sim/core/step_checks.h"

namespace fluid_sim
{
namespace
{
/// Points in a grid, for the question "is a point closer than sqrt(radius_sq) to one of them?" (at
/// most two spacings, the grid's cell): the boundary particles of some bodies, or the water an
/// earlier fluid block placed. Distances in Real, as the particles are stored.
class ProximityIndex
{
public:
  ProximityIndex(const SceneConfig& scene, const std::vector<Vec3>& pts, double radius_sq) : radius_sq_(Real(radius_sq))
  {
    if (pts.empty()) return;
    grid_ = std::make_unique<UniformGrid>(scene.domain.min, scene.domain.max, 2.0 * scene.spacing, 2);
    grid_->build(pts);
    points_.resize(grid_->numInside());
    for (std::size_t k = 0; k < points_.size(); ++k) points_[k] = pts[grid_->order()[k]];
  }

  /// The boundary particles of the bodies `select` picks.
  template <class Select>
  ProximityIndex(const SceneConfig& scene, const BodySet& bodies, double radius_sq, Select&& select)
      : ProximityIndex(scene, selected(bodies, select), radius_sq)
  {
  }

  bool near(const Vec3d& pos) const
  {
    if (!grid_) return false;
    const Vec3 p = pos.cast<Real>();
    bool found = false;
    grid_->forEachRange(p, 1, [&](Index begin, Index end) {
      for (Index k = begin; k < end && !found; ++k) found = (points_[k] - p).squaredNorm() < radius_sq_;
    });
    return found;
  }

private:
  template <class Select>
  static std::vector<Vec3> selected(const BodySet& bodies, Select&& select)
  {
    std::vector<Vec3> pts;
    for (const Body& body : bodies.bodies())
      if (select(body))
        pts.insert(pts.end(), bodies.x.begin() + body.offset, bodies.x.begin() + body.offset + body.local.size());
    return pts;
  }

  Real radius_sq_;  // m^2
  std::unique_ptr<UniformGrid> grid_;
  std::vector<Vec3> points_;  // m, world, in the grid's cell order
};

bool isOpenShell(const Body& body)
{
  return body.openShell();
}

/// Whether a point is left out: near an open shell, inside a solid, or, in a scene with
/// containers, inside none of them. Water may lie in any container (two tanks side by side, a
/// closed cup standing in a tank, water in both): before, a point outside any one container was
/// left out, so a second container dropped the other's water (all of it when nested, silently).
bool blockedByBody(const Vec3d& pos, const BodySet& bodies, const ProximityIndex& open_shells)
{
  return open_shells.near(pos) || outsideTheWater(pos, bodies);
}
}  // namespace

bool outsideTheWater(const Vec3d& pos, const BodySet& bodies)
{
  bool containers = false, in_a_container = false;
  for (const Body& body : bodies.bodies())
  {
    if (isOpenShell(body)) continue;
    const Vec3d local = body.pose.rotation.conjugate() * (pos - body.pose.translation);
    const bool in = insideShape(body.config, local);
    if (body.config.inside)
    {
      containers = true;
      in_a_container = in_a_container || in;
    }
    else if (in)
      return true;
  }
  return containers && !in_a_container;
}

double trimDistance(double spacing)
{
  return (1.0 - 1e-3) * spacing;
}

FillResult fillFluid(const SceneConfig& scene, const BodySet& bodies, FluidParticles& fluid)
{
  const double sp = scene.spacing;  // m
  // Open meshes (a cup, a paddle) have no inside: a lattice point closer than 0.75 s to one of
  // their boundary particles would start inside the shell's layer and be shot off in the first
  // step, so it is dropped like a point inside a solid.
  const ProximityIndex open_shells(scene, bodies, 0.75 * 0.75 * sp * sp, isOpenShell);
  // Eq. A21: a lattice point closer than one spacing to a boundary particle of a solid or a
  // container is trimmed. At a flat wall aligned with the lattice the first lattice point lies
  // half a spacing inside the surface and the layer half a spacing outside it, one spacing apart,
  // and there the layer's volumes (Eq. A3) make the point's density exactly rho0; nearer, the
  // wall alone raises it above rho0 (a curved or tilted wall cuts the lattice at any distance:
  // down to half a spacing from the layer, 20 % over rest density in a sphere).
  const bool trim = scene.fill.trim && !bodies.bodies().empty();
  const double trim_distance = trimDistance(sp);  // m
  const ProximityIndex walls(scene, bodies, trim_distance * trim_distance,
                             [trim](const Body& body) { return trim && !isOpenShell(body); });
  const Real rho0 = Real(scene.rest_density);
  FillResult result;
  const Vec3 domain_min = scene.domain.min.cast<Real>(), domain_max = scene.domain.max.cast<Real>();  // m
  // Blocks that overlap make their union. A lattice point strictly inside an earlier box block
  // is left out (a block listed twice, or two boxes making an L: the union's volume, each point
  // once), and so is one within half a spacing of an earlier block's particle (a seam where the
  // lattices meet off step) or within 0.9 s of a saved state's particle (its water is no
  // lattice: every point inside it lies within about 0.87 s of a particle, while water that only
  // touches it keeps a spacing). Before, each block was filled in full: a block listed twice
  // started at twice rest density, and the relaxation pushed the excess through the tank's walls.
  const auto insideEarlierBox = [&](const Vec3d& pos, std::size_t block_index) {
    for (std::size_t e = 0; e < block_index; ++e)
    {
      const FluidBlockConfig& earlier = scene.fluid[e];
      if (earlier.particles) continue;
      const double tol = 1e-9 * sp;  // m: a point on an earlier block's face is not inside it
      if ((pos.array() > earlier.box.min.array() + tol).all() && (pos.array() < earlier.box.max.array() - tol).all())
        return true;
    }
    return false;
  };
  for (std::size_t b = 0; b < scene.fluid.size(); ++b)
  {
    const FluidBlockConfig& block = scene.fluid[b];
    if (block.particles)
    {
      // A saved state: every particle as it is, in the given order (the order the step sorts
      // from, so a run resumed from a frame sorts as the uninterrupted run did). A particle the
      // step would remove (outside the domain) or the lattice would leave out (in a solid, outside
      // a container, on an open shell) is dropped and counted like a lattice point. Never trimmed:
      // its distance to a wall is the one the saved run left it at.
      const ExplicitParticles& p = *block.particles;
      for (std::size_t k = 0; k < p.positions.size(); ++k)
      {
        const Vec3d& pos = p.positions[k];
        if (!insideBox(pos.cast<Real>(), domain_min, domain_max) || blockedByBody(pos, bodies, open_shells))
        {
          ++result.dropped;
          continue;
        }
        fluid.add(pos.cast<Real>(), p.velocities[k].cast<Real>(), rho0);
        result.kind.push_back(FillKind::Explicit);
      }
      continue;
    }
    const Vec3d ext = block.box.max - block.box.min;
    // Cell-centred lattice at exactly the spacing (a stretched lattice would start under rest
    // density): a particle stands for the cube of side s around it, so a block that touches a
    // wall leaves the first particle half a spacing from it. A remainder of the extent that is
    // not a multiple of s is split evenly on both sides.
    int n[3];
    Vec3d start;
    for (int a = 0; a < 3; ++a)
    {
      n[a] = std::max(1, int(std::floor(ext[a] / sp + 1e-6)));
      start[a] = block.box.min[a] + 0.5 * (ext[a] - n[a] * sp) + 0.5 * sp;
    }
    // A block holds whole spacings per axis: say so when that leaves 15 % of its volume or more
    // empty (a 3.9 cm layer at 2 cm holds one layer, 2 cm of water; the robot benchmark's block
    // at 1.1 cm holds 90 % of itself, which is not worth a warning on every run).
    const double held = double(n[0]) * n[1] * n[2] * sp * sp * sp;  // m^3
    const double volume = ext.x() * ext.y() * ext.z();              // m^3
    if (held < 0.85 * volume)
    {
      const char* axis[3] = {"x", "y", "z"};
      std::string sizes;
      for (int a = 0; a < 3; ++a)
        if (ext[a] - n[a] * sp > 0.25 * sp)
          sizes += std::string(sizes.empty() ? "" : ", ") + numberText(ext[a]) + " m along " + axis[a] + " holds " +
                   std::to_string(n[a]) + (n[a] == 1 ? " layer" : " layers") + " (" + numberText(n[a] * sp) + " m)";
      result.warnings.push_back("fluid[" + std::to_string(b) + "].box: a block is filled with whole spacings (" +
                                numberText(sp) + " m) per axis: " + sizes + ", so it starts with " + numberText(held) +
                                " m^3 of water, " + numberText(std::round(100.0 * held / volume)) + " % of its " +
                                numberText(volume) + " m^3; give extents that are multiples of the spacing");
    }
    // The water the blocks before this one placed, lattice and saved apart (built once per block).
    std::vector<Vec3> lattice_water, saved_water;
    for (std::size_t k = 0; k < fluid.size(); ++k)
      (result.kind[k] == FillKind::Explicit ? saved_water : lattice_water).push_back(fluid.x[k]);
    const ProximityIndex earlier_lattice(scene, lattice_water, 0.25 * sp * sp);
    const ProximityIndex earlier_saved(scene, saved_water, 0.81 * sp * sp);
    for (int k = 0; k < n[2]; ++k)
      for (int j = 0; j < n[1]; ++j)
        for (int i = 0; i < n[0]; ++i)
        {
          const Vec3d pos = start + sp * Vec3d(i, j, k);
          if (blockedByBody(pos, bodies, open_shells))
          {
            ++result.dropped;
            continue;
          }
          if (walls.near(pos))
          {
            ++result.dropped;
            ++result.trimmed;
            continue;
          }
          if (b > 0 && (insideEarlierBox(pos, b) || earlier_lattice.near(pos) || earlier_saved.near(pos)))
          {
            ++result.dropped;
            ++result.overlapped;
            continue;
          }
          fluid.add(pos.cast<Real>(), block.velocity.cast<Real>(), rho0);
          // The block's outer layer is under rest density wherever it is a free surface (it lacks
          // the layer beyond); the relaxation must not draw it in (Eq. A22).
          const bool face = i == 0 || j == 0 || k == 0 || i == n[0] - 1 || j == n[1] - 1 || k == n[2] - 1;
          result.kind.push_back(face ? FillKind::LatticeFace : FillKind::LatticeInterior);
        }
  }
  // A scene whose water all comes from emitters starts dry.
  if (fluid.size() == 0 && !scene.fluid.empty())
    throw ConfigError(
        "fluid", "no fluid particle remains after removing those inside solids, outside containers" +
                     std::string(trim ? " or within a spacing of a wall's particle layer (fill.trim)" : "") + ": " +
                     std::to_string(result.dropped) + " left out, " + std::to_string(result.trimmed) +
                     " of them at walls");
  return result;
}

}  // namespace fluid_sim
