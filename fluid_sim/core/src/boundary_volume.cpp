// Volumes of boundary particles (Eq. A3, docs/method.md): V_b = gamma / sum_b' W(x_b - x_b') over
// one body's layer, and the flat-layer factor gamma the simulation uses. Declared in
// boundary_sampling.h.

#include <cmath>
#include <unordered_map>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "fluid_sim/core/boundary_sampling.h"
#include "fluid_sim/core/cell_key.h"
#include "fluid_sim/core/kernel.h"

namespace fluid_sim
{
double flatLayerFill(double spacing, double support, double distance)
{
  // s^3 * sum over a square lattice of spacing s in a plane, at `distance` from it, of W(r). At
  // distance 0 the terms are W(s sqrt(i^2 + j^2)) exactly (q = 0 adds nothing): the volume factor
  // below.
  const CubicKernel kernel{Real(support)};
  const int reach = int(std::ceil(support / spacing));
  const double q = distance / spacing;  // spacings
  double sum = 0.0;                     // 1/m^3
  for (int j = -reach; j <= reach; ++j)
    for (int i = -reach; i <= reach; ++i) sum += kernel.W(Real(spacing * std::sqrt(q * q + double(i * i + j * j))));
  return spacing * spacing * spacing * sum;
}

double flatLayerVolumeFactor(double spacing, double support)
{
  // gamma = c of a flat layer on its own plane: then a flat layer of spacing s gets V_b = s^3,
  // the volume of the fluid layer it stands in for.
  return flatLayerFill(spacing, support, 0.0);
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
  // A sparse grid of cells of the kernel support: memory follows the particles, not the bounding
  // box (a dense grid over two small triangles 100 m apart asked for tens of GB). Cells are
  // numbered from the box's lower corner less one cell, each cell keeps its points in input
  // order, and the neighbour cells are visited z, y, x ascending: the sums add the same terms in
  // the same order as the dense grid did (volumes unchanged bit for bit).
  const double inv_cell = 1.0 / support;
  const Vec3d origin = (lo - centre) - Vec3d::Constant(support);
  const auto cellOf = [&](const Vec3& p) {
    return CellKey{(long long)((double(p.x()) - origin.x()) * inv_cell),
                   (long long)((double(p.y()) - origin.y()) * inv_cell),
                   (long long)((double(p.z()) - origin.z()) * inv_cell)};
  };
  std::unordered_map<CellKey, std::vector<std::size_t>, CellKeyHash> cells;
  cells.reserve(points.size());
  std::vector<CellKey> cell_of(local.size());
  for (std::size_t i = 0; i < local.size(); ++i)
  {
    cell_of[i] = cellOf(local[i]);
    cells[cell_of[i]].push_back(i);
  }
  const CubicKernel kernel{Real(support)};
  const Real h2 = Real(support * support);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, local.size(), 1024),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i != r.end(); ++i)
                      {
                        const CellKey c = cell_of[i];
                        double sum = 0.0;  // 1/m^3
                        for (long long z = c.z - 1; z <= c.z + 1; ++z)
                          for (long long y = c.y - 1; y <= c.y + 1; ++y)
                            for (long long x = c.x - 1; x <= c.x + 1; ++x)
                            {
                              const auto it = cells.find(CellKey{x, y, z});
                              if (it == cells.end()) continue;
                              for (const std::size_t k : it->second)
                              {
                                const Real d2 = (local[i] - local[k]).squaredNorm();
                                if (d2 < h2) sum += kernel.W(std::sqrt(d2));
                              }
                            }
                        volumes[i] = Real(gamma / sum);  // sum > 0: it includes the point itself
                      }
                    });
  return volumes;
}

}  // namespace fluid_sim
