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
/// Open meshes (a cup, a paddle) have no inside: a lattice point closer than 0.75 s to one of
/// their boundary particles would start inside the shell's layer and be shot off in the first
/// step, so it is dropped like a point inside a solid.
class OpenShellIndex
{
public:
  OpenShellIndex(const SceneConfig& scene, const BodySet& bodies) : spacing_(scene.spacing)
  {
    std::vector<Vec3> pts;
    for (const Body& body : bodies.bodies())
      if (body.config.type == ShapeType::Mesh && !body.config.mesh_closed)
        pts.insert(pts.end(), bodies.x.begin() + body.offset, bodies.x.begin() + body.offset + body.local.size());
    if (pts.empty()) return;
    grid_ = std::make_unique<UniformGrid>(scene.domain.min, scene.domain.max, scene.spacing, 2);
    grid_->build(pts);
    points_.resize(grid_->numInside());
    for (std::size_t k = 0; k < points_.size(); ++k) points_[k] = pts[grid_->order()[k]];
  }

  bool near(const Vec3d& pos) const
  {
    if (!grid_) return false;
    const Vec3 p = pos.cast<Real>();
    const Real r2 = Real(0.75 * 0.75 * spacing_ * spacing_);  // m^2
    bool found = false;
    grid_->forEachRange(p, 1, [&](Index begin, Index end) {
      for (Index k = begin; k < end && !found; ++k) found = (points_[k] - p).squaredNorm() < r2;
    });
    return found;
  }

private:
  double spacing_;  // m
  std::unique_ptr<UniformGrid> grid_;
  std::vector<Vec3> points_;  // m, world, in the grid's cell order
};

bool blockedByBody(const Vec3d& pos, const BodySet& bodies, const OpenShellIndex& open_shells)
{
  if (open_shells.near(pos)) return true;
  for (const Body& body : bodies.bodies())
  {
    if (body.config.type == ShapeType::Mesh && !body.config.mesh_closed) continue;
    const Vec3d local = body.pose.rotation.conjugate() * (pos - body.pose.translation);
    const bool in = insideShape(body.config, local);
    if (body.config.inside ? !in : in) return true;
  }
  return false;
}
}  // namespace

std::size_t fillFluid(const SceneConfig& scene, const BodySet& bodies, FluidParticles& fluid)
{
  const OpenShellIndex open_shells(scene, bodies);
  const double sp = scene.spacing;  // m
  const Real rho0 = Real(scene.rest_density);
  std::size_t dropped = 0;
  const Vec3 domain_min = scene.domain.min.cast<Real>(), domain_max = scene.domain.max.cast<Real>();  // m
  for (const FluidBlockConfig& block : scene.fluid)
  {
    if (block.particles)
    {
      // A saved state: every particle as it is, in the given order (the order the step sorts
      // from, so a run resumed from a frame sorts as the uninterrupted run did). A particle the
      // step would remove (outside the domain) or the lattice would leave out (in a solid, outside
      // a container, on an open shell) is dropped and counted like a lattice point.
      const ExplicitParticles& p = *block.particles;
      for (std::size_t k = 0; k < p.positions.size(); ++k)
      {
        const Vec3d& pos = p.positions[k];
        if (!insideBox(pos.cast<Real>(), domain_min, domain_max) || blockedByBody(pos, bodies, open_shells))
        {
          ++dropped;
          continue;
        }
        fluid.add(pos.cast<Real>(), p.velocities[k].cast<Real>(), rho0);
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
            ++dropped;
            continue;
          }
          fluid.add(pos.cast<Real>(), block.velocity.cast<Real>(), rho0);
        }
  }
  if (fluid.size() == 0)
    throw ConfigError("fluid", "no fluid particle remains after removing those inside solids or outside containers");
  return dropped;
}

}  // namespace fluid_sim
