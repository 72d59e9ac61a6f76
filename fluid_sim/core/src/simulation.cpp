// DFSPH with mirrored, SPH- or MLS-extrapolated boundary pressure (METHOD.md; paper Algorithm 1).
//
// Layout of one step (Simulation::step):
//   1. pose bodies at t                      (scripted motion or the caller's poses)
//   2. sort fluid by cell, neighbour lists    (fluid-fluid, fluid-boundary, boundary-fluid if needed)
//   3. density, diagonal A_i, density rate
//   4. divergence solve                       -> v*
//   5. non-pressure accelerations (gravity, viscosity if enabled) -> v**
//   6. density solve                          -> v(t + dt); x(t + dt)
//   7. remove particles that left the domain; stability checks.
// The boundary method is a template parameter of the solver loops (chosen once per scene).

#include "fluid_sim/core/simulation.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>

#include "fluid_sim/core/boundary_pressure.h"
#include "fluid_sim/core/boundary_sampling.h"
#include "fluid_sim/core/kernel.h"
#include "fluid_sim/core/neighbor_search.h"

namespace fluid_sim
{
namespace
{
using Clock = std::chrono::steady_clock;
using Vec4 = Eigen::Matrix<Real, 4, 1>;  // a Vec3 padded with a 0 for packed arithmetic
double msSince(Clock::time_point t0)
{
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

constexpr std::size_t kGrain = 1024;  // fixed grain: deterministic reductions

/// body(range) over [0, n) in parallel, in chunks that depend on n and grain only. With TBB's
/// default (auto) partitioner the chunk boundaries follow work stealing, and the compiler's
/// vectorised loop body and its scalar remainder need not round alike, so an element's result
/// could change with the timing of the threads: two identical runs of bench_dam_break at 195 k
/// particles parted at step 110, and 3 or 4 threads gave other results than 1 or 2
/// (docs/method_notes.md). Every parallel loop of the step goes through here.
template <class Body>
void parallelRanges(std::size_t n, std::size_t grain, Body&& body)
{
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain), body, tbb::simple_partitioner());
}

/// f(i) for i in [0, n) in parallel (fixed chunks, see parallelRanges).
template <class F>
void parallelFor(std::size_t n, F&& f)
{
  parallelRanges(n, kGrain, [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) f(i);
  });
}

/// Deterministic sum over [0, n) of f(i) (double).
template <class F>
double parallelSum(std::size_t n, F&& f)
{
  return tbb::parallel_deterministic_reduce(
      tbb::blocked_range<std::size_t>(0, n, kGrain), 0.0,
      [&](const tbb::blocked_range<std::size_t>& r, double acc) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) acc += f(i);
        return acc;
      },
      [](double a, double b) { return a + b; });
}

template <class F>
double parallelMax(std::size_t n, F&& f)
{
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n, kGrain), 0.0,
      [&](const tbb::blocked_range<std::size_t>& r, double acc) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) acc = std::max(acc, double(f(i)));
        return acc;
      },
      [](double a, double b) { return std::max(a, b); });
}

/// Rotation vector (axis * angle, rad) of a rotation.
Vec3d rotationVector(const Eigen::Quaterniond& q)
{
  Eigen::AngleAxisd aa(q.normalized());
  double angle = aa.angle();
  if (angle > M_PI) angle -= 2.0 * M_PI;
  return aa.axis() * angle;
}

struct Body
{
  BoundaryConfig config;
  std::vector<Vec3d> local;  // body-frame samples, m
  std::size_t offset = 0;
  Pose pose;  // at the current time
  Pose initial_pose;
  Vec3d v_origin = Vec3d::Zero(), omega = Vec3d::Zero();  // m/s, rad/s (world)
  Vec3d a_origin = Vec3d::Zero(), alpha = Vec3d::Zero();  // m/s^2, rad/s^2 (world)
  bool moving = false;
  bool pose_pending = false;
  bool pose_jump = false;  // the pending pose is a placement, not a motion (no velocity from it)
  bool has_previous_pose = false;
  Pose pending_pose;
  double last_pose_time = 0.0;
  Vec3d force = Vec3d::Zero(), torque = Vec3d::Zero();  // world, last step
  std::size_t contact = 0;
  double max_pressure = 0.0;
};
}  // namespace

struct Simulation::Impl
{
  SceneConfig scene;
  Real s, h, rho0, mass;
  CubicKernel kernel;
  Vec3 gravity;
  double t = 0.0;
  double dt_next = 0.0;
  double a_ref = 0.0;  // |A_i| of a full neighbourhood, for the lone-particle guard

  // Fluid particles (structure of arrays). Persistent arrays are reordered together on each sort.
  std::vector<Vec3> x, v;
  std::vector<Real> rho, p, p_div;
  std::vector<Real> p_total;  // p + p_div of the last step (output only)
  // Per-step scratch (recomputed every step, not reordered).
  std::vector<Real> A, drho, src, kappa, err;
  // Positions, velocities and pressure accelerations padded to 4 components (the 4th is 0) for
  // the pair loops: a neighbour's vector is then one packed load, and a subtraction and a
  // multiply-add are one instruction each instead of three (m, m/s, m/s^2).
  std::vector<Vec4, Eigen::aligned_allocator<Vec4>> x4, a4, v4;
  std::vector<Vec3> grad_b;  // sum_b psi_b grad W_ib
  std::vector<Vec3> tmp_vec;
  std::vector<Real> tmp_real;
  std::vector<Index> tmp_index;

  // Boundary particles.
  std::vector<Body> bodies;
  std::vector<Vec3> xb, vb, ab;  // world position, velocity, acceleration
  std::vector<Real> Vb, pb, pb_const;
  std::vector<Index> body_of;
  std::vector<Vec3> xb_sorted;
  std::vector<std::uint8_t> active;
  std::vector<Index> active_list;
  bool any_moving = false;
  bool boundary_grid_valid = false;

  UniformGrid fluid_grid, boundary_grid;
  std::vector<Vec3> wall_dv;  // m/s, this step's velocity change from the p_b wall term (diagnostic)
  NeighborLists ff, fb, bf;   // ff/fb factor: grad W = factor * (x_i - x_j); bf factor: coefficient c_bf

  std::size_t initial_count = 0, removed_start = 0, removed_total = 0;
  std::size_t mls_fallbacks = 0, mls_reduced = 0;

  static const SceneConfig& validated(const SceneConfig& cfg)
  {
    validate(cfg);  // before any member (grids, kernel) is built from the values
    return cfg;
  }

  explicit Impl(const SceneConfig& cfg)
      : scene(validated(cfg))
      , s(Real(cfg.spacing))
      , h(Real(2.0 * cfg.spacing))
      , rho0(Real(cfg.rest_density))
      , mass(Real(cfg.rest_density * cfg.spacing * cfg.spacing * cfg.spacing))
      , kernel(Real(2.0 * cfg.spacing))
      , gravity(cfg.gravity.cast<Real>())
      // Grid cells of the kernel support h (m): a query visits 9 rows of 3 cells, ~24 candidates
      // each, long enough for the vector path of buildNeighborLists. With cells of one spacing
      // (25 rows of ~5) the search took 6.5 instead of 4.4 ms per step in bench_dam_break.
      , fluid_grid(cfg.domain.min, cfg.domain.max, 2 * cfg.spacing, 2)
      , boundary_grid(cfg.domain.min, cfg.domain.max, 2 * cfg.spacing, 2)
  {
    setupBodies();
    indexOpenShells();
    setupFluid();
    a_ref = referenceDiagonal();
    dt_next = computeTimeStep();
  }

  BoundaryPressureMethod method() const
  {
    return scene.solver.boundary_pressure;
  }

  // --------------------------------------------------------------------------------- set-up
  void setupBodies()
  {
    std::size_t offset = 0;
    for (const BoundaryConfig& cfg : scene.boundaries)
    {
      Body body;
      body.config = cfg;
      if (body.config.type == ShapeType::Cylinder) body.config.cylinder.axis.normalize();
      const double ss = cfg.sample_spacing > 0.0 ? cfg.sample_spacing : scene.spacing;
      body.local = sampleBoundary(body.config, ss, scene.spacing);
      body.offset = offset;
      body.initial_pose = cfg.pose;
      body.pose = cfg.pose;
      body.moving = cfg.externally_posed || !cfg.motion.isStatic();
      any_moving = any_moving || body.moving;
      offset += body.local.size();
      bodies.push_back(std::move(body));
    }
    xb.resize(offset);
    vb.assign(offset, Vec3::Zero());
    ab.assign(offset, Vec3::Zero());
    Vb.resize(offset);
    pb.assign(offset, 0);
    pb_const.assign(offset, 0);
    body_of.resize(offset);
    active.assign(offset, 0);
    const double gamma = flatLayerVolumeFactor(scene.spacing, 2.0 * scene.spacing);
    for (std::size_t bi = 0; bi < bodies.size(); ++bi)
    {
      Body& body = bodies[bi];
      const std::vector<Real> vol = fluid_sim::boundaryVolumes(body.local, 2.0 * scene.spacing, gamma);
      for (std::size_t k = 0; k < body.local.size(); ++k)
      {
        Vb[body.offset + k] = vol[k];
        body_of[body.offset + k] = Index(bi);
      }
      poseBody(body, 0.0, true);
    }
  }

  void setupFluid()
  {
    const double sp = scene.spacing;
    for (const FluidBlockConfig& block : scene.fluid)
    {
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
            if (blockedByBody(pos))
            {
              ++removed_start;
              continue;
            }
            x.push_back(pos.cast<Real>());
            v.push_back(block.velocity.cast<Real>());
          }
    }
    if (x.empty())
      throw ConfigError("fluid", "no fluid particle remains after removing those inside solids or outside containers");
    const std::size_t n = x.size();
    rho.assign(n, rho0);
    p.assign(n, 0);
    p_div.assign(n, 0);
    p_total.assign(n, 0);
    initial_count = n;
  }

  bool blockedByBody(const Vec3d& pos) const
  {
    if (open_shells && nearOpenShell(pos)) return true;
    for (const Body& body : bodies)
    {
      if (body.config.type == ShapeType::Mesh && !body.config.mesh_closed) continue;
      const Vec3d local = body.pose.rotation.conjugate() * (pos - body.pose.translation);
      const bool in = insideShape(body.config, local);
      if (body.config.inside ? !in : in) return true;
    }
    return false;
  }

  /// Open meshes (a cup, a paddle) have no inside: a lattice point closer than 0.75 s to one of
  /// their boundary particles would start inside the shell's layer and be shot off in the first
  /// step, so it is dropped like a point inside a solid.
  std::unique_ptr<UniformGrid> open_shells;
  std::vector<Vec3> open_shell_points;  // m, world, in open_shells' cell order

  void indexOpenShells()
  {
    std::vector<Vec3> pts;
    for (const Body& body : bodies)
      if (body.config.type == ShapeType::Mesh && !body.config.mesh_closed)
        pts.insert(pts.end(), xb.begin() + body.offset, xb.begin() + body.offset + body.local.size());
    if (pts.empty()) return;
    open_shells = std::make_unique<UniformGrid>(scene.domain.min, scene.domain.max, scene.spacing, 2);
    open_shells->build(pts);
    open_shell_points.resize(open_shells->numInside());
    for (std::size_t k = 0; k < open_shell_points.size(); ++k) open_shell_points[k] = pts[open_shells->order()[k]];
  }

  bool nearOpenShell(const Vec3d& pos) const
  {
    const Vec3 p = pos.cast<Real>();
    const Real r2 = Real(0.75 * 0.75 * scene.spacing * scene.spacing);
    bool near = false;
    open_shells->forEachRange(p, 1, [&](Index begin, Index end) {
      for (Index k = begin; k < end && !near; ++k) near = (open_shell_points[k] - p).squaredNorm() < r2;
    });
    return near;
  }

  /// |A_i| for a particle in a full cubic lattice (no boundary), the scale of the diagonal.
  double referenceDiagonal() const
  {
    Vec3 g = Vec3::Zero();
    double sq = 0.0, density = mass * kernel.W0();
    for (int k = -2; k <= 2; ++k)
      for (int j = -2; j <= 2; ++j)
        for (int i = -2; i <= 2; ++i)
        {
          if (i == 0 && j == 0 && k == 0) continue;
          const Vec3 r = Vec3(Real(i), Real(j), Real(k)) * s;
          const Vec3 gw = kernel.gradW(r);
          g += mass * gw;
          sq += double(mass) * mass * gw.squaredNorm();
          density += mass * kernel.W(r);
        }
    return (g.squaredNorm() + sq) / (density * density);
  }

  // --------------------------------------------------------------------------------- bodies
  /// Scripted pose at time `time`: rotation about `about` at constant angular velocity, then translation.
  Pose scriptedPose(const Body& body, double time) const
  {
    const MotionConfig& m = body.config.motion;
    const double w = m.angular_velocity.norm();
    Eigen::Quaterniond rot = Eigen::Quaterniond::Identity();
    if (w > 0.0) rot = Eigen::Quaterniond(Eigen::AngleAxisd(w * time, m.angular_velocity / w));
    Pose pose;
    pose.rotation = (rot * body.initial_pose.rotation).normalized();
    pose.translation = m.about + rot * (body.initial_pose.translation - m.about) + m.linear_velocity * time;
    return pose;
  }

  /// Moves body to its pose at `time` and writes its particles' world positions and velocities.
  void poseBody(Body& body, double time, bool force_write)
  {
    if (body.config.externally_posed)
    {
      if (body.pose_pending)
      {
        const double dt = time - body.last_pose_time;
        if (body.pose_jump)
        {
          body.v_origin.setZero();
          body.omega.setZero();
          body.a_origin.setZero();
          body.alpha.setZero();
        }
        else if (body.has_previous_pose && dt > 0.0)
        {
          // Velocities follow the poses: backward differences over the last interval.
          const Vec3d v_new = (body.pending_pose.translation - body.pose.translation) / dt;
          const Vec3d w_new = rotationVector(body.pending_pose.rotation * body.pose.rotation.conjugate()) / dt;
          body.a_origin = (v_new - body.v_origin) / dt;
          body.alpha = (w_new - body.omega) / dt;
          body.v_origin = v_new;
          body.omega = w_new;
        }
        body.pose = body.pending_pose;
        body.last_pose_time = time;
        body.has_previous_pose = true;
        body.pose_pending = false;
        force_write = true;
      }
    }
    else if (!body.config.motion.isStatic())
    {
      const MotionConfig& m = body.config.motion;
      body.pose = scriptedPose(body, time);
      body.omega = m.angular_velocity;
      body.v_origin = m.angular_velocity.cross(body.pose.translation - m.about) + m.linear_velocity;
      body.alpha.setZero();
      body.a_origin = m.angular_velocity.cross(m.angular_velocity.cross(body.pose.translation - m.about));
      force_write = true;
    }
    if (!force_write) return;
    const Mat3d R = body.pose.rotation.toRotationMatrix();
    const Vec3d o = body.pose.translation;
    const std::size_t n = body.local.size();
    parallelFor(n, [&](std::size_t k) {
      const Vec3d r = R * body.local[k];  // from the body origin, world axes
      const std::size_t b = body.offset + k;
      xb[b] = (o + r).cast<Real>();
      vb[b] = (body.v_origin + body.omega.cross(r)).cast<Real>();
      ab[b] = (body.a_origin + body.alpha.cross(r) + body.omega.cross(body.omega.cross(r))).cast<Real>();
    });
    boundary_grid_valid = false;
  }

  // --------------------------------------------------------------------------------- time step
  double computeTimeStep() const
  {
    const TimeStepConfig& ts = scene.time_step;
    if (!ts.adaptive) return ts.fixed;
    const double vmax = parallelMax(v.size(), [&](std::size_t i) { return v[i].norm(); });
    // CFL: dt = lambda s / max|v|; at rest the gravity-driven speed after one max step bounds it.
    const double speed = std::max(vmax, gravity.norm() * ts.max);
    return std::clamp(ts.cfl * scene.spacing / std::max(speed, 1e-12), ts.min, ts.max);
  }

  // --------------------------------------------------------------------------------- neighbours
  /// Sorts fluid particles by cell, reordering every persistent per-particle array together.
  void sortFluid()
  {
    fluid_grid.build(x);
    const std::vector<Index>& order = fluid_grid.order();
    const std::size_t n = x.size();  // all inside: particles outside the domain were removed
    reorder(x, order, tmp_vec);
    reorder(v, order, tmp_vec);
    reorder(rho, order, tmp_real);
    reorder(p, order, tmp_real);
    reorder(p_div, order, tmp_real);
    // After reordering, the grid's sorted positions are the particle indices themselves.
    x4.resize(n);  // the padded copy the solver's pair loops read
    parallelFor(n, [&](std::size_t i) { x4[i] << x[i], Real(0); });
  }

  template <class T>
  static void reorder(std::vector<T>& data, const std::vector<Index>& order, std::vector<T>& tmp)
  {
    tmp.resize(data.size());
    parallelFor(data.size(), [&](std::size_t k) { tmp[k] = data[order[k]]; });
    data.swap(tmp);
  }

  void buildNeighbors()
  {
    const CubicKernel& kern = kernel;
    // grad W(r) = factor * r  (factor = dW/dr / |r|, 1/m^5)
    auto gradFactor = [&kern](Real d2) -> Real { return kern.gradFactor(std::sqrt(d2)); };
    // W(r) per pair too (1/m^3): the density and XSPH passes then need no square root and, for
    // XSPH, no position gather per pair (+4 B per pair).
    auto weight = [&kern](Real d2) -> Real { return kern.W(std::sqrt(d2)); };
    static const std::vector<Index> kIdentity;
    buildNeighborLists(x, fluid_grid, x, kIdentity, h, true, gradFactor, weight, ff);
    if (!xb.empty())
    {
      if (!boundary_grid_valid)
      {
        boundary_grid.build(xb);
        const std::size_t nin = boundary_grid.numInside();
        xb_sorted.resize(nin);
        for (std::size_t k = 0; k < nin; ++k) xb_sorted[k] = xb[boundary_grid.order()[k]];
        boundary_grid_valid = true;
      }
      buildNeighborLists(x, boundary_grid, xb_sorted, boundary_grid.order(), h, false, gradFactor, weight, fb);
    }
    else
    {
      fb.offset.assign(x.size() + 1, 0);
      fb.index.clear();
      fb.factor.clear();
      fb.weight.clear();
    }
    if (method() != BoundaryPressureMethod::Mirroring) buildBoundaryFluidLists();
  }

  /// Boundary-fluid lists for active boundary particles (those with a fluid neighbour), with the
  /// MLS fit radius or the kernel support for SPH; factor = W(r) of that radius for now.
  void buildBoundaryFluidLists()
  {
    std::fill(active.begin(), active.end(), 0);
    parallelFor(x.size(), [&](std::size_t i) {
      for (Index k = fb.offset[i]; k < fb.offset[i + 1]; ++k)
        active[fb.index[k]] = 1;  // benign: every writer stores the same value
    });
    active_list.clear();
    for (std::size_t b = 0; b < active.size(); ++b)
      if (active[b]) active_list.push_back(Index(b));
    tmp_vec.resize(active_list.size());
    std::vector<Vec3>& queries = tmp_vec;
    for (std::size_t k = 0; k < active_list.size(); ++k) queries[k] = xb[active_list[k]];
    const Real radius = method() == BoundaryPressureMethod::Mls ? Real(scene.solver.mls_fit_radius * scene.spacing) : h;
    const CubicKernel fit_kernel(radius);
    auto weight = [&fit_kernel](Real d2) -> Real { return fit_kernel.W(std::sqrt(d2)); };
    static const std::vector<Index> kIdentity;
    buildNeighborLists(queries, fluid_grid, x, kIdentity, radius, false, weight, bf);
  }

  // --------------------------------------------------------------------------------- fields
  /// Density (kg/m^3), DFSPH diagonal A_i, boundary gradient sum, and the density rate
  /// (D rho / Dt)_i with the current velocities (kg/m^3/s; what computeDensityRate() gives, done
  /// here in the same pass over the pairs because the divergence solve needs it next).
  void computeDensityAndDiagonal()
  {
    const std::size_t n = x.size();
    A.resize(n);
    drho.resize(n);
    grad_b.resize(n);
    padVelocities();
    parallelFor(n, [&](std::size_t i) {
      const Vec3 xi = x[i], vi = v[i];
      const Vec4 xi4 = x4[i], vi4 = v4[i];
      Real density = mass * kernel.W0();
      Vec4 gf4 = Vec4::Zero(), sq4 = Vec4::Zero(), rate4 = Vec4::Zero();
      for (Index k = ff.offset[i]; k < ff.offset[i + 1]; ++k)
      {
        const Index j = ff.index[k];
        density += mass * ff.weight[k];
        const Vec4 g = ff.factor[k] * (xi4 - x4[j]);
        gf4 += g;
        sq4 += g.cwiseProduct(g);
        rate4 += (vi4 - v4[j]).cwiseProduct(g);
      }
      const Vec3 gf = gf4.template head<3>();
      const Real sq = sq4.sum();
      Real rate = mass * rate4.sum();
      Vec3 gb = Vec3::Zero();
      for (Index k = fb.offset[i]; k < fb.offset[i + 1]; ++k)
      {
        const Index b = fb.index[k];
        const Vec3 r = xi - xb[b];
        const Real psi = rho0 * Vb[b];  // kg: the boundary particle's rest mass (Akinci)
        density += psi * fb.weight[k];
        const Vec3 g = (psi * fb.factor[k]) * r;
        gb += g;
        rate += (vi - vb[b]).dot(g);
      }
      rho[i] = density;
      drho[i] = rate;
      grad_b[i] = gb;
      const Vec3 gsum = mass * gf + gb;
      // Diagonal of the discrete divergence of a^p with respect to p_i (METHOD.md step 2).
      A[i] = -(gsum.squaredNorm() + mass * mass * sq) / (density * density);
      if (method() == BoundaryPressureMethod::Mirroring)
        A[i] -= gb.dot(gsum) / (rho0 * rho0);  // Eq. 2: p_b = p_i adds (p_i/rho0^2) grad_b to a_i
      if (-A[i] < 1e-6 * a_ref) A[i] = 0;      // lone particle: no pressure
    });
  }

  /// v4 = v padded (see x4).
  void padVelocities()
  {
    v4.resize(v.size());
    parallelFor(v.size(), [&](std::size_t i) { v4[i] << v[i], Real(0); });
  }

  /// (D rho / Dt)_i with the current velocities, kg/m^3/s.
  void computeDensityRate()
  {
    padVelocities();
    parallelFor(x.size(), [&](std::size_t i) {
      const Vec3 xi = x[i], vi = v[i];
      const Vec4 xi4 = x4[i], vi4 = v4[i];
      Vec4 sum = Vec4::Zero();
      for (Index k = ff.offset[i]; k < ff.offset[i + 1]; ++k)
      {
        const Index j = ff.index[k];
        sum += ff.factor[k] * (vi4 - v4[j]).cwiseProduct(xi4 - x4[j]);
      }
      Real rate = mass * sum.sum();
      for (Index k = fb.offset[i]; k < fb.offset[i + 1]; ++k)
      {
        const Index b = fb.index[k];
        rate += rho0 * Vb[b] * fb.factor[k] * (vi - vb[b]).dot(xi - xb[b]);
      }
      drho[i] = rate;
    });
  }

  /// Extrapolation coefficients for the active boundary particles (fixed during both solves).
  void computeExtrapolationCoefficients()
  {
    const BoundaryPressureMethod m = method();
    std::fill(pb_const.begin(), pb_const.end(), 0);
    const std::size_t na = active_list.size();
    std::vector<std::size_t> fit_kind(na, 0);
    parallelRanges(na, 256, [&](const tbb::blocked_range<std::size_t>& r) {
      std::vector<Real> w;
      for (std::size_t q = r.begin(); q != r.end(); ++q)
      {
        const Index b = active_list[q];
        const Index begin = bf.offset[q];
        const int cnt = int(bf.offset[q + 1] - begin);
        const Index* idx = bf.index.data() + begin;
        Real* c = bf.factor.data() + begin;
        auto pos = [&](int k) -> const Vec3& { return x[idx[k]]; };
        if (m == BoundaryPressureMethod::Mls)
        {
          w.resize(cnt);
          for (int k = 0; k < cnt; ++k) w[k] = c[k] * (mass / rho[idx[k]]);  // V_f W_bf (Eq. 7-14 weights)
          const MlsFit fit = mlsCoefficients(xb[b], cnt, pos, w.data(), scene.solver.mls_fit_radius * scene.spacing,
                                             scene.solver.mls_eigen_tolerance, scene.solver.mls_singular, c);
          fit_kind[q] = std::size_t(fit);
        }
        else
        {
          w.assign(c, c + cnt);
          auto dens = [&](int k) { return rho[idx[k]]; };
          sphCoefficients(xb[b], cnt, pos, dens, w.data(), Vec3(gravity - ab[b]), c, pb_const[b]);
        }
      }
    });
    mls_fallbacks = mls_reduced = 0;
    if (m == BoundaryPressureMethod::Mls)
      for (std::size_t k : fit_kind)
      {
        mls_fallbacks += k == std::size_t(MlsFit::Fallback);
        mls_reduced += k == std::size_t(MlsFit::Reduced);
      }
  }

  // --------------------------------------------------------------------------------- solver
  /// p_b for every active boundary particle from the fluid pressures `pf` (Eq. 3 / Eq. 15).
  /// `hydrostatic` adds the SPH constant term (density solve only); `clamp` enforces p_b >= 0.
  void extrapolateBoundaryPressure(const std::vector<Real>& pf, bool hydrostatic, bool clamp)
  {
    const bool limit = scene.solver.limit_boundary_pressure;
    // solver.limit_boundary_pressure: p_b within [min p_f, max p_f] +- rho0 |g - a_b| 5 s (Pa).
    // The hydrostatic difference between the wall and its nearest water is about 1 s; the rest
    // is margin for the pressure noise of a converged solve: with 1.5 s the limiter clipped that
    // noise at rest and biased the submerged cube's buoyancy from 1.037 to 1.094 (3 s: 1.053;
    // 5 s: 1.036-1.045, unchanged), while 5 s still keeps MLS stable at 2 ms in the cylinder dam
    // break (unlimited: a particle shot off at 0.28 s).
    const Real reach = Real(5.0 * scene.spacing) * rho0;
    parallelRanges(active_list.size(), 512, [&](const tbb::blocked_range<std::size_t>& r) {
      for (std::size_t q = r.begin(); q != r.end(); ++q)
      {
        const Index b = active_list[q];
        Real value = hydrostatic ? pb_const[b] : Real(0);
        const Index begin = bf.offset[q], end = bf.offset[q + 1];
        if (begin == end)
        {
          pb[b] = 0;  // no fluid neighbour (METHOD.md choice 5)
          continue;
        }
        Real lo = pf[bf.index[begin]], hi = lo;
        for (Index k = begin; k < end; ++k)
        {
          const Real p = pf[bf.index[k]];
          value += bf.factor[k] * p;
          lo = std::min(lo, p);
          hi = std::max(hi, p);
        }
        if (limit)
        {
          const Real widen = reach * (gravity - ab[b]).norm();
          value = std::clamp(value, lo - widen, hi + widen);
        }
        pb[b] = clamp ? std::max(value, Real(0)) : value;
      }
    });
  }

  /// Pressure acceleration a^p (Eq. 1, or Eq. 2 for mirroring) from pressures pf; m/s^2. With
  /// kRecordWall (the final evaluation of a solve) it also adds wall_dt (s) times the p_b part of
  /// the wall term, -sum_b psi_b (p_b/rho0^2) grad W_ib, to wall_dv: at the end of the step
  /// sum_i m wall_dv_i . v_i is that term's work (StepReport::boundary_pressure_work).
  template <BoundaryPressureMethod M, bool kRecordWall = false>
  void computePressureAcceleration(const std::vector<Real>& pf, Real wall_dt = 0)
  {
    const std::size_t n = x.size();
    kappa.resize(n);
    parallelFor(n, [&](std::size_t i) { kappa[i] = pf[i] / (rho[i] * rho[i]); });
    a4.resize(n);
    const Real inv_rho0_sq = Real(1) / (rho0 * rho0);
    parallelFor(n, [&](std::size_t i) {
      const Vec3 xi = x[i];
      const Real ki = kappa[i];
      const Vec4 xi4 = x4[i];
      Vec4 acc4 = Vec4::Zero();
      for (Index k = ff.offset[i]; k < ff.offset[i + 1]; ++k)
      {
        const Index j = ff.index[k];
        acc4 -= (mass * (ki + kappa[j]) * ff.factor[k]) * (xi4 - x4[j]);
      }
      Vec3 acc = acc4.template head<3>();
      if constexpr (M == BoundaryPressureMethod::Mirroring)
      {
        // Eq. 2: p_b = p_i, so the boundary term is (p_i/rho_i^2 + p_i/rho0^2) sum_b psi_b grad W_ib.
        acc -= (ki + pf[i] * inv_rho0_sq) * grad_b[i];
        if constexpr (kRecordWall) wall_dv[i] -= (wall_dt * pf[i] * inv_rho0_sq) * grad_b[i];
      }
      else
      {
        // Eq. 1 with the stored p_b: (p_i/rho_i^2) grad_b + sum_b psi_b p_b/rho0^2 grad W_ib.
        Vec3 wall = Vec3::Zero();
        for (Index k = fb.offset[i]; k < fb.offset[i + 1]; ++k)
        {
          const Index b = fb.index[k];
          wall -= (rho0 * Vb[b] * pb[b] * inv_rho0_sq * fb.factor[k]) * (xi - xb[b]);
        }
        acc += wall - ki * grad_b[i];
        if constexpr (kRecordWall) wall_dv[i] += wall_dt * wall;
      }
      a4[i] << acc, Real(0);
    });
  }

  /// One relaxed Jacobi sweep: D_i = div of a^p (METHOD.md), p_i += omega (s_i - D_i)/A_i.
  /// Returns the mean positive relative density error dt^2 (D_i - s_i)/rho0 of the pressures
  /// before this update.
  double jacobiUpdate(std::vector<Real>& pf, double dt, bool clamp_p)
  {
    const std::size_t n = x.size();
    err.resize(n);
    const Real omega = Real(scene.solver.omega);
    const Real dt2_over_rho0 = Real(dt * dt / rho0);
    const bool warm = scene.solver.warm_start;
    parallelFor(n, [&](std::size_t i) {
      const Vec4 xi = x4[i], ai = a4[i];
      // Component-wise products summed over the pairs, the three components added once at the end.
      Vec4 sum = Vec4::Zero();
      for (Index k = ff.offset[i]; k < ff.offset[i + 1]; ++k)
      {
        const Index j = ff.index[k];
        sum += ff.factor[k] * (ai - a4[j]).cwiseProduct(xi - x4[j]);
      }
      Real div = mass * sum.sum();
      div += ai.template head<3>().dot(grad_b[i]);  // boundary particles are not accelerated by the fluid
      const Real residual = div - src[i];
      // residual > 0: compression left. With a warm start the first guess can also be too high
      // (a stale pressure on a particle that no longer needs it) and then residual < 0 is an
      // error too, so wherever a pressure acts its |residual| counts; from zero (cold start) the
      // iteration approaches from below and the positive part is the error (DFSPH's measure).
      const Real counted = (warm && pf[i] != 0) ? std::abs(residual) : std::max(residual, Real(0));
      err[i] = counted * dt2_over_rho0;
      if (A[i] != 0)
      {
        Real next = pf[i] - omega * residual / A[i];
        pf[i] = clamp_p ? std::max(next, Real(0)) : next;
      }
    });
    return parallelSum(n, [&](std::size_t i) { return double(err[i]); }) / double(std::max<std::size_t>(n, 1));
  }

  template <BoundaryPressureMethod M>
  void prepareBoundary(const std::vector<Real>& pf, bool density_solve)
  {
    if constexpr (M != BoundaryPressureMethod::Mirroring)
      extrapolateBoundaryPressure(pf, density_solve && M == BoundaryPressureMethod::SphExtrapolation,
                                  density_solve && scene.solver.clamp_boundary_pressure);
    else
    {
      (void)pf;
      (void)density_solve;
    }
  }

  /// Iterates a solve; on return `a` holds the final pressure acceleration (with p_b recomputed
  /// from the final p, METHOD.md choice 2). Returns iterations; writes error and convergence.
  template <BoundaryPressureMethod M>
  int solve(std::vector<Real>& pf, double dt, bool density_solve, double tol, int min_it, double& error,
            bool& converged)
  {
    const int max_it = scene.solver.max_iterations;
    int it = 0;
    error = 0.0;
    converged = false;
    while (it < max_it)
    {
      prepareBoundary<M>(pf, density_solve);
      computePressureAcceleration<M>(pf);
      error = jacobiUpdate(pf, dt, density_solve);
      ++it;
      if (it >= min_it && error <= tol)
      {
        converged = true;
        break;
      }
    }
    prepareBoundary<M>(pf, density_solve);
    computePressureAcceleration<M, true>(pf, Real(dt));  // the final a^p, also adding to wall_dv
    return it;
  }

  /// Adds the pressure forces of the current `a` evaluation (pressures pf, p_b) to body wrenches.
  template <BoundaryPressureMethod M>
  void accumulateBodyForces(const std::vector<Real>& pf, std::vector<Vec3d>& fsum)
  {
    const std::size_t nb = bodies.size();
    if (nb == 0) return;
    const Real inv_rho0_sq = Real(1) / (rho0 * rho0);
    std::vector<Vec3d> init(2 * nb, Vec3d::Zero());
    std::vector<Vec3d> total = tbb::parallel_deterministic_reduce(
        tbb::blocked_range<std::size_t>(0, x.size(), kGrain), init,
        [&](const tbb::blocked_range<std::size_t>& r, std::vector<Vec3d> acc) {
          for (std::size_t i = r.begin(); i != r.end(); ++i)
          {
            if (fb.offset[i] == fb.offset[i + 1]) continue;
            const Real ki = kappa[i];
            for (Index k = fb.offset[i]; k < fb.offset[i + 1]; ++k)
            {
              const Index b = fb.index[k];
              const Real pbv = M == BoundaryPressureMethod::Mirroring ? pf[i] : pb[b];
              // Newton's third law: the force on b is minus the force on i from b.
              const Vec3 f = (mass * rho0 * Vb[b] * (ki + pbv * inv_rho0_sq) * fb.factor[k]) * (x[i] - xb[b]);
              const Index body = body_of[b];
              const Vec3d fd = f.template cast<double>();
              acc[2 * body] += fd;
              acc[2 * body + 1] += (xb[b].template cast<double>() - bodies[body].pose.translation).cross(fd);
            }
          }
          return acc;
        },
        [](std::vector<Vec3d> l, const std::vector<Vec3d>& r) {
          for (std::size_t k = 0; k < l.size(); ++k) l[k] += r[k];
          return l;
        });
    for (std::size_t k = 0; k < total.size(); ++k) fsum[k] += total[k];
  }

  // --------------------------------------------------------------------------------- non-pressure
  /// Gravity and, when the scene enables it, viscosity: v** = v* + dt a^np. Adds boundary
  /// viscous reactions to fsum.
  void applyNonPressure(double dt, std::vector<Vec3d>& fsum)
  {
    const std::size_t n = x.size();
    const Real dtr = Real(dt);
    const ViscosityConfig& visc = scene.viscosity;
    if (visc.model == ViscosityModel::None || (visc.coefficient == 0.0 && visc.boundary == 0.0))
    {
      parallelFor(n, [&](std::size_t i) { v[i] += dtr * gravity; });
      return;
    }
    tmp_vec.resize(n);
    std::vector<Vec3>& dv = tmp_vec;
    const Real nu = Real(visc.coefficient), nub = Real(visc.boundary);
    const bool xsph = visc.model == ViscosityModel::Xsph;
    const Real eps = Real(0.01) * h * h;
    // Fluid volumes m_j/rho_j (m^3), once per particle rather than a division per pair.
    tmp_real.resize(n);
    std::vector<Real>& vol = tmp_real;
    parallelFor(n, [&](std::size_t i) { vol[i] = mass / rho[i]; });
    if (xsph) padVelocities();
    parallelFor(n, [&](std::size_t i) {
      const Vec3 xi = x[i], vi = v[i];
      Vec3 acc = Vec3::Zero();
      if (xsph)
      {
        // XSPH: v_i += c sum_j (m_j/rho_j) (v_j - v_i) W_ij, with W_ij stored in the lists.
        const Vec4 vi4 = v4[i];
        Vec4 acc4 = Vec4::Zero();
        for (Index k = ff.offset[i]; k < ff.offset[i + 1]; ++k)
        {
          const Index j = ff.index[k];
          acc4 -= (nu * vol[j] * ff.weight[k]) * (vi4 - v4[j]);
        }
        acc = acc4.template head<3>();
        if (nub != 0)
          for (Index k = fb.offset[i]; k < fb.offset[i + 1]; ++k)
          {
            const Index b = fb.index[k];
            acc -= (nub * Vb[b] * fb.weight[k]) * (vi - vb[b]);
          }
      }
      else
      {
        // Artificial viscosity: a_i = 2(d+2) nu sum_j m_j/rho_j (v_ij.r_ij)/(r^2+0.01h^2) grad W_ij.
        for (Index k = ff.offset[i]; k < ff.offset[i + 1]; ++k)
        {
          const Index j = ff.index[k];
          const Vec3 r = xi - x[j];
          const Vec3 vij = vi - v[j];
          acc += (Real(10) * nu * vol[j] * vij.dot(r) / (r.squaredNorm() + eps) * ff.factor[k]) * r;
        }
        if (nub != 0)
          for (Index k = fb.offset[i]; k < fb.offset[i + 1]; ++k)
          {
            const Index b = fb.index[k];
            const Vec3 r = xi - xb[b];
            const Vec3 vib = vi - vb[b];
            acc += (Real(10) * nub * Vb[b] * vib.dot(r) / (r.squaredNorm() + eps) * fb.factor[k]) * r;
          }
      }
      dv[i] = xsph ? acc : Vec3(acc * dtr);  // XSPH is a velocity correction, not an acceleration
    });
    if (nub > 0 && !bodies.empty())
    {
      // Reaction on bodies: the momentum the fluid lost to boundary viscosity, per unit time.
      for (std::size_t i = 0; i < n; ++i)
        for (Index k = fb.offset[i]; k < fb.offset[i + 1]; ++k)
        {
          const Index b = fb.index[k];
          const Vec3 r = x[i] - xb[b];
          const Vec3 vib = v[i] - vb[b];
          Vec3 dvb =
              xsph ? Vec3(-(nub * Vb[b] * fb.weight[k]) * vib)
                   : Vec3((Real(10) * nub * Vb[b] * vib.dot(r) / (r.squaredNorm() + eps) * fb.factor[k]) * r * dtr);
          const Vec3d f = -(double(mass) / dt) * dvb.cast<double>();
          const Index body = body_of[b];
          fsum[2 * body] += f;
          fsum[2 * body + 1] += (xb[b].cast<double>() - bodies[body].pose.translation).cross(f);
        }
    }
    parallelFor(n, [&](std::size_t i) { v[i] += dv[i] + dtr * gravity; });
  }

  /// First guess of a solve whose source `src` is set: zero, or with solver.warm_start the
  /// previous step's pressure where the water is compressing now (src < 0) and is at or above
  /// rest density. A stale pressure on a particle that has since left the bulk (a splash, with one
  /// or two neighbours, a density near 0.3 rho0 and a tiny diagonal) would accelerate it by
  /// p/rho^2 before the two minimum iterations could bring it down: with the plain previous
  /// pressure the dam breaks blew up for every boundary method (particles at 100-200 m/s by
  /// 0.26-0.42 s; docs/method_notes.md).
  void startingPressure(std::vector<Real>& pf)
  {
    if (!scene.solver.warm_start)
    {
      std::fill(pf.begin(), pf.end(), Real(0));
      return;
    }
    parallelFor(pf.size(), [&](std::size_t i) {
      if (!(src[i] < 0 && rho[i] >= rho0)) pf[i] = 0;
    });
  }

  // --------------------------------------------------------------------------------- step
  template <BoundaryPressureMethod M>
  StepReport stepImpl()
  {
    const auto t0 = Clock::now();
    StepReport rep;
    const double dt = dt_next;
    const std::size_t n0 = x.size();

    for (Body& body : bodies)
      if (body.moving) poseBody(body, t, false);

    auto tn = Clock::now();
    sortFluid();
    buildNeighbors();
    rep.ms_neighbors = msSince(tn);
    rep.neighbor_pairs = ff.pairs() + fb.pairs();

    computeDensityAndDiagonal();
    if (M != BoundaryPressureMethod::Mirroring) computeExtrapolationCoefficients();
    rep.max_density_error = parallelMax(x.size(), [&](std::size_t i) { return (rho[i] - rho0) / rho0; });

    const std::size_t n = x.size();
    src.resize(n);
    wall_dv.assign(n, Vec3::Zero());
    std::vector<Vec3d> fsum(2 * bodies.size(), Vec3d::Zero());

    // Divergence solve (METHOD.md step 3): only compression counts at the free surface.
    auto td = Clock::now();
    if (scene.solver.divergence_solve)
    {
      // drho from computeDensityAndDiagonal(): the velocities have not changed since.
      parallelFor(n, [&](std::size_t i) { src[i] = -std::max(drho[i], Real(0)) / Real(dt); });
      startingPressure(p_div);
      rep.divergence_iterations =
          solve<M>(p_div, dt, false, scene.solver.divergence_error, scene.solver.min_divergence_iterations,
                   rep.divergence_error, rep.divergence_converged);
      parallelFor(n, [&](std::size_t i) { v[i] += Real(dt) * a4[i].template head<3>(); });
      accumulateBodyForces<M>(p_div, fsum);
    }
    rep.ms_divergence = msSince(td);

    applyNonPressure(dt, fsum);

    // Density solve (METHOD.md step 5).
    auto tp = Clock::now();
    computeDensityRate();
    const Real inv_dt = Real(1.0 / dt), inv_dt2 = Real(1.0 / (dt * dt));
    parallelFor(n, [&](std::size_t i) { src[i] = (rho0 - rho[i]) * inv_dt2 - drho[i] * inv_dt; });
    startingPressure(p);
    rep.density_iterations = solve<M>(p, dt, true, scene.solver.density_error, scene.solver.min_iterations,
                                      rep.density_error, rep.density_converged);
    accumulateBodyForces<M>(p, fsum);
    parallelFor(n, [&](std::size_t i) {
      v[i] += Real(dt) * a4[i].template head<3>();
      x[i] += Real(dt) * v[i];
    });
    rep.ms_density = msSince(tp);
    rep.boundary_pressure_work =
        double(mass) * parallelSum(n, [&](std::size_t i) { return double(wall_dv[i].dot(v[i])); });
    p_total.resize(n);
    parallelFor(n, [&](std::size_t i) { p_total[i] = p[i] + (scene.solver.divergence_solve ? p_div[i] : Real(0)); });

    updateBodyReports(fsum);
    t += dt;
    rep.time = t;
    rep.dt = dt;

    checkAndRemove(rep, dt);
    rep.fluid_particles = x.size();
    rep.active_boundary = M == BoundaryPressureMethod::Mirroring ? countContacts() : active_list.size();
    rep.mls_fallbacks = mls_fallbacks;
    rep.mls_reduced = mls_reduced;
    (void)n0;
    dt_next = computeTimeStep();
    rep.ms_total = msSince(t0);
    return rep;
  }

  std::size_t countContacts() const
  {
    std::size_t total = 0;
    for (const Body& b : bodies) total += b.contact;
    return total;
  }

  void updateBodyReports(const std::vector<Vec3d>& fsum)
  {
    for (std::size_t k = 0; k < bodies.size(); ++k)
    {
      bodies[k].force = fsum[2 * k];
      bodies[k].torque = fsum[2 * k + 1];
      bodies[k].contact = 0;
      bodies[k].max_pressure = 0.0;
    }
    if (bodies.empty()) return;
    // Contact statistics from the fluid-boundary lists (serial: cheap, per boundary pair).
    std::fill(active.begin(), active.end(), 0);
    for (std::size_t i = 0; i < x.size(); ++i)
      for (Index k = fb.offset[i]; k < fb.offset[i + 1]; ++k)
      {
        const Index b = fb.index[k];
        Body& body = bodies[body_of[b]];
        const double pbv = method() == BoundaryPressureMethod::Mirroring ? double(p[i]) : double(pb[b]);
        body.max_pressure = std::max(body.max_pressure, pbv);
        if (!active[b])
        {
          active[b] = 1;
          ++body.contact;
        }
      }
  }

  /// Reports non-finite states and blow-ups; removes particles that left the domain.
  void checkAndRemove(StepReport& rep, double dt)
  {
    const std::size_t n = x.size();
    const double nonfinite =
        parallelSum(n, [&](std::size_t i) { return (x[i].allFinite() && v[i].allFinite()) ? 0.0 : 1.0; });
    rep.max_speed = parallelMax(n, [&](std::size_t i) { return v[i].norm(); });
    rep.kinetic_energy = 0.5 * double(mass) * parallelSum(n, [&](std::size_t i) { return double(v[i].squaredNorm()); });
    if (nonfinite > 0)
    {
      rep.unstable = true;
      rep.reason = std::to_string(std::size_t(nonfinite)) + " particles with non-finite position or velocity";
    }
    else if (rep.density_error > scene.stability.max_density_error)
    {
      std::ostringstream os;
      os << "mean density error " << rep.density_error << " above stability.max_density_error "
         << scene.stability.max_density_error;
      rep.unstable = true;
      rep.reason = os.str();
    }
    else if (rep.max_speed * dt > scene.stability.max_cfl * scene.spacing)
    {
      std::ostringstream os;
      os << "max speed " << rep.max_speed << " m/s moves " << rep.max_speed * dt / scene.spacing
         << " spacings per step, above stability.max_cfl " << scene.stability.max_cfl;
      rep.unstable = true;
      rep.reason = os.str();
    }
    if (rep.unstable) return;  // keep the state as it is for inspection: nothing removed, nothing hidden
    const Vec3 lo = scene.domain.min.cast<Real>(), hi = scene.domain.max.cast<Real>();
    std::size_t kept = 0;
    for (std::size_t i = 0; i < n; ++i)
    {
      const bool inside = (x[i].array() >= lo.array()).all() && (x[i].array() <= hi.array()).all();
      if (!inside) continue;
      if (kept != i)
      {
        x[kept] = x[i];
        v[kept] = v[i];
        rho[kept] = rho[i];
        p[kept] = p[i];
        p_div[kept] = p_div[i];
        p_total[kept] = p_total[i];
      }
      ++kept;
    }
    rep.removed = n - kept;
    removed_total += rep.removed;
    x.resize(kept);
    v.resize(kept);
    rho.resize(kept);
    p.resize(kept);
    p_div.resize(kept);
    p_total.resize(kept);
  }

  StepReport step()
  {
    switch (method())
    {
      case BoundaryPressureMethod::Mirroring:
        return stepImpl<BoundaryPressureMethod::Mirroring>();
      case BoundaryPressureMethod::SphExtrapolation:
        return stepImpl<BoundaryPressureMethod::SphExtrapolation>();
      case BoundaryPressureMethod::Mls:
        return stepImpl<BoundaryPressureMethod::Mls>();
    }
    return {};
  }
};

Simulation::Simulation(const SceneConfig& scene) : impl_(std::make_unique<Impl>(scene)) {}
Simulation::~Simulation() = default;

StepReport Simulation::step()
{
  return impl_->step();
}

void Simulation::setBodyPose(std::size_t index, const Pose& pose, bool jump)
{
  if (index >= impl_->bodies.size()) throw ConfigError("body", "no body with index " + std::to_string(index));
  Body& body = impl_->bodies[index];
  if (!body.config.externally_posed)
    throw ConfigError(body.config.name, "body is not externally posed (set `external: true`)");
  body.pending_pose = pose;
  body.pose_pending = true;
  body.pose_jump = jump;
}

void Simulation::updateSettings(const SolverConfig& solver, const ViscosityConfig& viscosity,
                                const StabilityConfig& stability)
{
  const SolverConfig& old = impl_->scene.solver;
  if (solver.boundary_pressure != old.boundary_pressure)
    throw ConfigError("solver.boundary_pressure",
                      "is fixed when the simulation is built (" + std::string(toString(old.boundary_pressure)) + ")");
  if (solver.mls_fit_radius != old.mls_fit_radius || solver.mls_eigen_tolerance != old.mls_eigen_tolerance ||
      solver.mls_singular != old.mls_singular)
    throw ConfigError("solver.mls_fit_radius", "the MLS fit settings are fixed when the simulation is built");
  SceneConfig next = impl_->scene;
  next.solver = solver;
  next.viscosity = viscosity;
  next.stability = stability;
  validate(next);  // throws before anything changes
  impl_->scene.solver = solver;
  impl_->scene.viscosity = viscosity;
  impl_->scene.stability = stability;
}

std::size_t Simulation::bodyIndex(const std::string& name) const
{
  for (std::size_t k = 0; k < impl_->bodies.size(); ++k)
    if (impl_->bodies[k].config.name == name) return k;
  throw ConfigError(name, "no boundary body with this name");
}

double Simulation::time() const
{
  return impl_->t;
}
double Simulation::nextTimeStep() const
{
  return impl_->dt_next;
}
const SceneConfig& Simulation::scene() const
{
  return impl_->scene;
}
std::size_t Simulation::numFluidParticles() const
{
  return impl_->x.size();
}
const std::vector<Vec3>& Simulation::positions() const
{
  return impl_->x;
}
const std::vector<Vec3>& Simulation::velocities() const
{
  return impl_->v;
}
const std::vector<Real>& Simulation::pressures() const
{
  return impl_->p_total;
}
const std::vector<Real>& Simulation::densitySolvePressures() const
{
  return impl_->p;
}
const std::vector<Real>& Simulation::divergenceSolvePressures() const
{
  return impl_->p_div;
}
const std::vector<Real>& Simulation::densities() const
{
  return impl_->rho;
}
std::size_t Simulation::numBodies() const
{
  return impl_->bodies.size();
}

BodyInfo Simulation::body(std::size_t index) const
{
  const Body& b = impl_->bodies.at(index);
  BodyInfo info;
  info.name = b.config.name;
  info.inside = b.config.inside;
  info.moving = b.moving;
  info.first_particle = b.offset;
  info.num_particles = b.local.size();
  info.pose = b.pose;
  info.linear_velocity = b.v_origin;
  info.angular_velocity = b.omega;
  info.force = b.force;
  info.torque = b.torque;
  info.force_body = b.pose.rotation.conjugate() * b.force;
  info.torque_body = b.pose.rotation.conjugate() * b.torque;
  info.contact_particles = b.contact;
  info.max_pressure = b.max_pressure;
  return info;
}

const std::vector<Vec3>& Simulation::boundaryPositions() const
{
  return impl_->xb;
}
const std::vector<Real>& Simulation::boundaryPressures() const
{
  return impl_->pb;
}
const std::vector<Real>& Simulation::boundaryVolumes() const
{
  return impl_->Vb;
}
std::size_t Simulation::initialFluidParticles() const
{
  return impl_->initial_count;
}
std::size_t Simulation::removedAtStart() const
{
  return impl_->removed_start;
}
std::size_t Simulation::removedTotal() const
{
  return impl_->removed_total;
}
double Simulation::particleMass() const
{
  return impl_->mass;
}

}  // namespace fluid_sim
