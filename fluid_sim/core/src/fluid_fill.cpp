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
/// The boundary particles of a set of bodies in a grid, for the question "is a point closer than
/// sqrt(radius_sq) to one of them?" (at most two spacings, the grid's cell). Distances in Real, as
/// the particles are stored.
class ProximityIndex
{
public:
  template <class Select>
  ProximityIndex(const SceneConfig& scene, const BodySet& bodies, double radius_sq, Select&& select)
      : radius_sq_(Real(radius_sq))
  {
    std::vector<Vec3> pts;
    for (const Body& body : bodies.bodies())
      if (select(body))
        pts.insert(pts.end(), bodies.x.begin() + body.offset, bodies.x.begin() + body.offset + body.local.size());
    if (pts.empty()) return;
    grid_ = std::make_unique<UniformGrid>(scene.domain.min, scene.domain.max, 2.0 * scene.spacing, 2);
    grid_->build(pts);
    points_.resize(grid_->numInside());
    for (std::size_t k = 0; k < points_.size(); ++k) points_[k] = pts[grid_->order()[k]];
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
  if (open_shells.near(pos)) return true;
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
}  // namespace

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
  for (const FluidBlockConfig& block : scene.fluid)
  {
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
          fluid.add(pos.cast<Real>(), block.velocity.cast<Real>(), rho0);
          // The block's outer layer is under rest density wherever it is a free surface (it lacks
          // the layer beyond); the relaxation must not draw it in (Eq. A22).
          const bool face = i == 0 || j == 0 || k == 0 || i == n[0] - 1 || j == n[1] - 1 || k == n[2] - 1;
          result.kind.push_back(face ? FillKind::LatticeFace : FillKind::LatticeInterior);
        }
  }
  // A scene whose water all comes from emitters starts dry.
  if (fluid.size() == 0 && !scene.fluid.empty())
    throw ConfigError("fluid", "no fluid particle remains after removing those inside solids or outside containers");
  return result;
}

}  // namespace fluid_sim
