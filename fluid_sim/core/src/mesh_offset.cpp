// The offset surface of a triangle mesh (offsetMesh): every face moved along its normal, the
// vertices mitred where faces meet. sampleBoundary() samples it to place a closed mesh's boundary
// layer half a spacing into the solid (or out of a container) without gaps along the edges.

#include <cmath>

#include <Eigen/Eigenvalues>

#include "fluid_sim/core/boundary_sampling.h"

namespace fluid_sim
{
TriangleMesh offsetMesh(const TriangleMesh& mesh, double offset)
{
  // Each vertex moves by the d that best satisfies d . n_f = offset for the faces around it
  // (weighted by the face's angle at the vertex): d = offset n on a flat patch, the mitred corner
  // offset * (n1 + n2 + n3) at a box corner. Directions the faces do not constrain (the tangent
  // plane of a flat patch) get no motion: the pseudo-inverse drops eigenvalues below 1 % of the
  // largest. |d| is capped at 3 |offset| (sharp spikes).
  TriangleMesh out;
  out.vertices = mesh.vertices;
  out.triangles = mesh.triangles;
  if (offset == 0.0) return out;
  // Per vertex, the normal equations a d = b: a = sum angle n n^T (rad), b = sum angle offset n (rad m).
  std::vector<Mat3d> a(mesh.vertices.size(), Mat3d::Zero());
  std::vector<Vec3d> b(mesh.vertices.size(), Vec3d::Zero());
  for (const auto& t : mesh.triangles)
  {
    const Vec3d n = (mesh.vertices[t[1]] - mesh.vertices[t[0]]).cross(mesh.vertices[t[2]] - mesh.vertices[t[0]]);
    const double length = n.norm();
    if (!(length > 0.0) || !std::isfinite(length)) continue;
    const Vec3d unit = n / length;
    for (int k = 0; k < 3; ++k)
    {
      const Vec3d e1 = mesh.vertices[t[(k + 1) % 3]] - mesh.vertices[t[k]];
      const Vec3d e2 = mesh.vertices[t[(k + 2) % 3]] - mesh.vertices[t[k]];
      const double angle = std::atan2(e1.cross(e2).norm(), e1.dot(e2));  // rad, at vertex t[k]
      a[t[k]] += angle * unit * unit.transpose();
      b[t[k]] += angle * offset * unit;
    }
  }
  for (std::size_t i = 0; i < out.vertices.size(); ++i)
  {
    const Eigen::SelfAdjointEigenSolver<Mat3d> eig(a[i]);
    const double largest = eig.eigenvalues().maxCoeff();
    if (!(largest > 0.0)) continue;
    Vec3d d = Vec3d::Zero();  // m
    for (int k = 0; k < 3; ++k)
      if (eig.eigenvalues()[k] > 0.01 * largest)
        d += eig.eigenvectors().col(k) * (eig.eigenvectors().col(k).dot(b[i]) / eig.eigenvalues()[k]);
    const double cap = 3.0 * std::abs(offset);
    if (d.norm() > cap) d *= cap / d.norm();
    out.vertices[i] += d;
  }
  return out;
}

}  // namespace fluid_sim
