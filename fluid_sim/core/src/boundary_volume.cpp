// Volumes of boundary particles (Eq. A3, docs/method.md): V_b = gamma / sum_b' W(x_b - x_b') over
// one body's layer, and the flat-layer factor gamma the simulation uses. Declared in
// boundary_sampling.h.

#include <cmath>

#include "fluid_sim/core/boundary_sampling.h"
#include "fluid_sim/core/kernel.h"
#include "fluid_sim/core/neighbor_search.h"

namespace fluid_sim
{
double flatLayerVolumeFactor(double spacing, double support)
{
  // gamma = s^3 * sum over a square lattice of spacing s in a plane of W(r): then a flat layer of
  // spacing s gets V_b = s^3, the volume of the fluid layer it stands in for.
  const CubicKernel kernel{Real(support)};
  const int reach = int(std::ceil(support / spacing));
  double sum = 0.0;  // 1/m^3
  for (int j = -reach; j <= reach; ++j)
    for (int i = -reach; i <= reach; ++i) sum += kernel.W(Real(spacing * std::sqrt(double(i * i + j * j))));
  return spacing * spacing * spacing * sum;
}

std::vector<Real> boundaryVolumes(const std::vector<Vec3d>& points, double support, double gamma)
{
  std::vector<Real> volumes(points.size(), Real(0));
  if (points.empty()) return volumes;
  Vec3d lo = points[0], hi = points[0];
  for (const auto& p : points)
  {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  // Local frame around the bounding box centre keeps float coordinates precise.
  const Vec3d centre = 0.5 * (lo + hi);
  std::vector<Vec3> local(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) local[i] = (points[i] - centre).cast<Real>();
  UniformGrid grid(lo - centre, hi - centre, support, 1);
  grid.build(local);
  std::vector<Vec3> sorted(local.size());
  for (std::size_t k = 0; k < local.size(); ++k) sorted[k] = local[grid.order()[k]];
  const CubicKernel kernel{Real(support)};
  const Real h2 = Real(support * support);
  for (std::size_t i = 0; i < local.size(); ++i)
  {
    double sum = 0.0;  // 1/m^3
    grid.forEachRange(local[i], 1, [&](Index begin, Index end) {
      for (Index k = begin; k < end; ++k)
      {
        const Real d2 = (local[i] - sorted[k]).squaredNorm();
        if (d2 < h2) sum += kernel.W(std::sqrt(d2));
      }
    });
    volumes[i] = Real(gamma / sum);  // sum > 0: it includes the point itself
  }
  return volumes;
}

}  // namespace fluid_sim
