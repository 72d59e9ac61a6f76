#pragma once
// The fluid particles: one structure of arrays whose persistent fields are listed once, in
// forEachField(). Sorting (reorder) and removal (keepIf) go through that list, so a field added
// there is carried along by both.

#include <cstdint>
#include <vector>

#include "fluid_sim/core/parallel.h"
#include "fluid_sim/core/types.h"

namespace fluid_sim
{
struct FluidParticles
{
  std::vector<Vec3> x;             // m, position
  std::vector<Vec3> v;             // m/s, velocity
  std::vector<Real> rho;           // kg/m^3, density (Eq. A1 of docs/method.md)
  std::vector<Real> p_density;     // Pa, pressure of the density solve (warm start, output)
  std::vector<Real> p_divergence;  // Pa, pressure of the divergence solve (warm start, output)
  std::vector<Real> p_total;       // Pa, p_density + p_divergence of the last step (output)

  /// The registry: f(field) for every per-particle field that belongs to a particle from step to
  /// step. Per-step scratch (the solver's diagonal, sources, accelerations) is not listed: it is
  /// recomputed after every sort.
  template <class F>
  void forEachField(F&& f)
  {
    f(x);
    f(v);
    f(rho);
    f(p_density);
    f(p_divergence);
    f(p_total);
  }

  std::size_t size() const
  {
    return x.size();
  }

  /// Appends one particle at rest density with zero pressures.
  void add(const Vec3& position, const Vec3& velocity, Real rest_density)
  {
    x.push_back(position);
    v.push_back(velocity);
    rho.push_back(rest_density);
    p_density.push_back(0);
    p_divergence.push_back(0);
    p_total.push_back(0);
  }

  /// Room for n particles in every field and in the sort's scratch (which trades storage with the
  /// fields at every sort): appending up to n then allocates nothing.
  void reserve(std::size_t n)
  {
    forEachField([&](auto& field) { field.reserve(n); });
    scratch_vec3_.reserve(n);
    scratch_real_.reserve(n);
  }

  /// Every field f becomes f[order[k]] at k (a permutation of [0, size())).
  void reorder(const std::vector<Index>& order)
  {
    forEachField([&](auto& field) { permute(field, order); });
  }

  /// Keeps the particles with keep[i] != 0, in their order; returns how many were removed.
  std::size_t keepIf(const std::vector<std::uint8_t>& keep)
  {
    const std::size_t n = size();
    std::size_t kept = 0;
    for (std::size_t i = 0; i < n; ++i) kept += keep[i] != 0;
    if (kept == n) return 0;
    forEachField([&](auto& field) {
      std::size_t next = 0;
      for (std::size_t i = 0; i < n; ++i)
        if (keep[i]) field[next++] = field[i];
      field.resize(kept);
    });
    return n - kept;
  }

private:
  // One scratch array per element type, swapped with the field it reorders: no allocation per sort.
  std::vector<Vec3> scratch_vec3_;
  std::vector<Real> scratch_real_;
  std::vector<Vec3>& scratchFor(const std::vector<Vec3>&)
  {
    return scratch_vec3_;
  }
  std::vector<Real>& scratchFor(const std::vector<Real>&)
  {
    return scratch_real_;
  }

  template <class T>
  void permute(std::vector<T>& data, const std::vector<Index>& order)
  {
    std::vector<T>& tmp = scratchFor(data);
    tmp.resize(data.size());
    parallelFor(data.size(), [&](std::size_t k) { tmp[k] = data[order[k]]; });
    data.swap(tmp);
  }
};

}  // namespace fluid_sim
