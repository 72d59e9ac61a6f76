// Free rigid bodies: mass properties, the Newton-Euler step (Eqs. A24, A25 of docs/method.md) and
// contacts between bodies on their boundary particles (Eq. A26).

#include "fluid_sim/core/rigid_dynamics.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "fluid_sim/core/bodies.h"

namespace fluid_sim
{
namespace
{
std::string num(double v)
{
  std::ostringstream os;
  os << v;
  return os.str();
}

std::string vecText(const Vec3d& v)
{
  return "[" + num(v.x()) + ", " + num(v.y()) + ", " + num(v.z()) + "]";
}

/// |d|^2 I - d d^T: the parallel-axis term per unit mass (m^2).
Mat3d parallelAxis(const Vec3d& d)
{
  return d.squaredNorm() * Mat3d::Identity() - d * d.transpose();
}

/// A closed mesh's volume, centroid and unit-density inertia about the centroid, summed over the
/// signed tetrahedra (origin, a, b, c): each contributes det/6 of volume, its centroid weighted so,
/// and the second moments det/120 (a a^T + b b^T + c c^T + s s^T), s = a + b + c, from which the
/// inertia is trace(C) I - C.
ShapeMass meshMass(const TriangleMesh& mesh)
{
  ShapeMass out;
  Vec3d first = Vec3d::Zero();   // m^4
  Mat3d second = Mat3d::Zero();  // m^5, covariance about the origin
  // Relative to a vertex of the mesh, not the body origin: a mesh far from its origin keeps its
  // digits.
  const Vec3d ref = mesh.vertices.empty() ? Vec3d::Zero() : mesh.vertices.front();
  for (const auto& t : mesh.triangles)
  {
    const Vec3d a = mesh.vertices[t[0]] - ref, b = mesh.vertices[t[1]] - ref, c = mesh.vertices[t[2]] - ref;
    const double det = a.dot(b.cross(c));  // m^3, six times the signed volume
    out.volume += det / 6.0;
    first += det / 24.0 * (a + b + c);
    const Vec3d s = a + b + c;
    second += det / 120.0 * (a * a.transpose() + b * b.transpose() + c * c.transpose() + s * s.transpose());
  }
  if (!(out.volume > 0.0)) return out;
  const Vec3d centroid = first / out.volume;  // relative to ref
  const Mat3d about_ref = second.trace() * Mat3d::Identity() - second;
  out.inertia = about_ref - out.volume * parallelAxis(centroid);
  out.centroid = centroid + ref;
  return out;
}
}  // namespace

Mat3d inertiaMatrix(const std::array<double, 6>& i)
{
  Mat3d m;
  m << i[0], i[3], i[4], i[3], i[1], i[5], i[4], i[5], i[2];
  return m;
}

ShapeMass shapeMass(const BoundaryConfig& b, const std::string& key)
{
  ShapeMass out;
  switch (b.type)
  {
    case ShapeType::Box:
    {
      const Vec3d e = b.box.max - b.box.min;  // m, edge lengths
      out.volume = e.prod();
      out.centroid = 0.5 * (b.box.min + b.box.max);
      const Vec3d sq = e.cwiseProduct(e);
      out.inertia = (out.volume / 12.0 * Vec3d(sq.y() + sq.z(), sq.x() + sq.z(), sq.x() + sq.y())).asDiagonal();
      break;
    }
    case ShapeType::Sphere:
    {
      const double r = b.sphere.radius;
      out.volume = 4.0 / 3.0 * M_PI * r * r * r;
      out.centroid = b.sphere.center;
      out.inertia = 0.4 * out.volume * r * r * Mat3d::Identity();
      break;
    }
    case ShapeType::Cylinder:
    {
      const double r = b.cylinder.radius, l = b.cylinder.length;
      const Vec3d axis = b.cylinder.axis.normalized();
      out.volume = M_PI * r * r * l;
      out.centroid = b.cylinder.center;
      const double i_axis = 0.5 * out.volume * r * r;                   // about the axis
      const double i_perp = out.volume * (3.0 * r * r + l * l) / 12.0;  // about a diameter
      out.inertia = i_perp * (Mat3d::Identity() - axis * axis.transpose()) + i_axis * axis * axis.transpose();
      break;
    }
    case ShapeType::Mesh:
    {
      if (!b.mesh_closed)
        throw ConfigError(key, "'" + b.name +
                                   "' is an open mesh, which has no volume: give mass (kg), inertia (kg m^2, about the "
                                   "centre of mass) and center_of_mass (m, body frame)");
      out = meshMass(b.mesh);
      if (!(out.volume > 0.0))
        throw ConfigError(
            key, "the mesh of '" + b.name + "' encloses no positive volume (" + num(out.volume) +
                     " m^3: its faces point inward or do not close); give mass and inertia, or fix its normals");
      break;
    }
  }
  return out;
}

MassProperties massProperties(const BoundaryConfig& b, const std::string& key)
{
  const DynamicConfig& d = b.dynamic;
  MassProperties out;
  const bool need_shape = d.density > 0.0 || !d.inertia || !d.center_of_mass;
  ShapeMass shape;
  if (need_shape) shape = shapeMass(b, key);
  out.mass = d.mass > 0.0 ? d.mass : d.density * shape.volume;
  out.com = d.center_of_mass ? *d.center_of_mass : shape.centroid;
  if (d.inertia)
    out.inertia = inertiaMatrix(*d.inertia);
  else
  {
    // The shape's inertia scaled to the mass, moved to the given centre of mass (parallel axes).
    out.inertia = out.mass / shape.volume * shape.inertia + out.mass * parallelAxis(out.com - shape.centroid);
  }
  if (!(out.mass > 0.0) || !std::isfinite(out.mass))
    throw ConfigError(key, "'" + b.name + "' has no positive mass (" + num(out.mass) + " kg)");
  return out;
}

// ------------------------------------------------------------------------------------ contacts

ContactSolver::ContactSolver(double spacing, const ContactConfig& config) : distance_(spacing), config_(config) {}

namespace
{
constexpr int kContactIterations = 20;
// Overlap left uncorrected (a fraction of the contact distance) and the fraction of the rest
// pushed apart per step (Baumgarte): small enough that a body at rest on another does not bounce.
constexpr double kSlop = 0.02;
constexpr double kPushFraction = 0.2;

std::int64_t cellKey(const Vec3d& x, double cell)
{
  const auto c = [&](double v) { return std::int64_t(std::floor(v / cell)) & 0x1FFFFF; };
  return (c(x.x()) << 42) | (c(x.y()) << 21) | c(x.z());
}
}  // namespace

void ContactSolver::find(const BodySet& bodies, double dt)
{
  contacts_.clear();
  // Pairs closer than the contact distance plus what a free body's surface can travel in one
  // step (speculative contacts: a fast body meets the wall in the step it would pass it).
  double speed = 0.0;  // m/s, fastest surface point of a free body
  Vec3d lo = Vec3d::Constant(1e300), hi = Vec3d::Constant(-1e300);
  for (const Body& body : bodies.bodies())
  {
    if (!body.free) continue;
    const Vec3d c = body.centerOfMass();
    double reach = 0.0;  // m, farthest particle from the centre of mass
    for (std::size_t k = 0; k < body.local.size(); ++k)
    {
      const Vec3d x = bodies.x[body.offset + k].cast<double>();
      lo = lo.cwiseMin(x);
      hi = hi.cwiseMax(x);
      reach = std::max(reach, (x - c).norm());
    }
    speed = std::max(speed, body.v_com.norm() + body.omega.norm() * reach);
  }
  const double cutoff = distance_ + std::min(2.0 * distance_, 2.0 * speed * dt);  // m
  lo -= Vec3d::Constant(cutoff);
  hi += Vec3d::Constant(cutoff);
  // Every boundary particle in reach of a free body's box, hashed by cells of the cutoff.
  grid_.clear();
  for (std::size_t j = 0; j < bodies.numParticles(); ++j)
  {
    const Vec3d x = bodies.x[j].cast<double>();
    if ((x.array() < lo.array()).any() || (x.array() > hi.array()).any()) continue;
    grid_[cellKey(x, cutoff)].push_back(std::uint32_t(j));
  }
  const double cutoff2 = cutoff * cutoff;
  // Inverse inertias (world axes at the step's start) once per free body, not per pair.
  std::vector<Mat3d> inv_i(bodies.size(), Mat3d::Zero());
  for (std::size_t k = 0; k < bodies.size(); ++k)
    if (bodies[k].free) inv_i[k] = bodies[k].inverseInertiaWorld();
  for (std::size_t a = 0; a < bodies.size(); ++a)
  {
    const Body& body = bodies[a];
    if (!body.free) continue;
    const Vec3d ca = body.centerOfMass();
    for (std::size_t k = 0; k < body.local.size(); ++k)
    {
      const std::size_t i = body.offset + k;
      const Vec3d xi = bodies.x[i].cast<double>();
      for (int dx = -1; dx <= 1; ++dx)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dz = -1; dz <= 1; ++dz)
          {
            const auto it = grid_.find(cellKey(xi + cutoff * Vec3d(dx, dy, dz), cutoff));
            if (it == grid_.end()) continue;
            for (std::uint32_t j : it->second)
            {
              const std::size_t bj = bodies.body_of[j];
              // Not with itself, and each pair of free bodies once (from the lower index).
              if (bj == a || (bodies[bj].free && bj < a)) continue;
              const Vec3d xj = bodies.x[j].cast<double>();
              const Vec3d d = xi - xj;
              const double r2 = d.squaredNorm();
              if (r2 >= cutoff2 || r2 == 0.0) continue;
              const double r = std::sqrt(r2);
              Contact c;
              c.a = std::uint32_t(a);
              c.b = bodies[bj].free ? std::int32_t(bj) : -1;
              c.particle_b = j;
              c.n = d / r;
              const Vec3d p = 0.5 * (xi + xj);  // m, contact point
              c.ra = p - ca;
              c.rb = c.b >= 0 ? Vec3d(p - bodies[bj].centerOfMass()) : Vec3d::Zero();
              c.gap = r - distance_;
              // 1 / (1/m_a + n . ((I_a^-1 (r_a x n)) x r_a) + the same for b).
              double k_inv = 1.0 / body.mass + c.n.dot((inv_i[a] * c.ra.cross(c.n)).cross(c.ra));
              if (c.b >= 0) k_inv += 1.0 / bodies[bj].mass + c.n.dot((inv_i[bj] * c.rb.cross(c.n)).cross(c.rb));
              c.mass_n = 1.0 / k_inv;
              contacts_.push_back(c);
            }
          }
    }
  }
}

void ContactSolver::apply(BodySet& bodies, double dt)
{
  for (std::size_t k = 0; k < bodies.size(); ++k) bodies[k].contact_force.setZero();
  find(bodies, dt);
  if (contacts_.empty()) return;
  // Inverse inertias once per body (world axes at the step's start).
  std::vector<Mat3d> inv_i(bodies.size(), Mat3d::Zero());
  for (std::size_t k = 0; k < bodies.size(); ++k)
    if (bodies[k].free) inv_i[k] = bodies[k].inverseInertiaWorld();
  const auto pointVelocity = [&](const Contact& c, bool of_a) -> Vec3d {
    if (of_a)
    {
      const Body& a = bodies[c.a];
      return a.v_com + a.omega.cross(c.ra);
    }
    if (c.b >= 0)
    {
      const Body& b = bodies[std::size_t(c.b)];
      return b.v_com + b.omega.cross(c.rb);
    }
    return bodies.v[c.particle_b].cast<double>();  // kinematic: the particle's own velocity
  };
  const auto applyImpulse = [&](const Contact& c, const Vec3d& j) {
    Body& a = bodies[c.a];
    a.v_com += j / a.mass;
    a.omega += inv_i[c.a] * c.ra.cross(j);
    a.contact_force += j / dt;
    if (c.b >= 0)
    {
      Body& b = bodies[std::size_t(c.b)];
      b.v_com -= j / b.mass;
      b.omega -= inv_i[std::size_t(c.b)] * c.rb.cross(j);
      b.contact_force -= j / dt;
    }
    else
      bodies[bodies.body_of[c.particle_b]].contact_force -= j / dt;  // the reaction on a kinematic body
  };
  // Eq. A26: sequential impulses. The normal velocity of each contact is held at or above its
  // target: -gap/dt while apart (it may close the gap, not pass it), a push of a fraction of the
  // overlap beyond the slop while overlapping; friction within the Coulomb cone of the normal
  // impulse.
  for (int it = 0; it < kContactIterations; ++it)
    for (Contact& c : contacts_)
    {
      const Vec3d v_rel = pointVelocity(c, true) - pointVelocity(c, false);
      const double vn = v_rel.dot(c.n);  // m/s, > 0 separating
      const double overlap = -c.gap - kSlop * distance_;
      const double target = c.gap > 0.0 ? -c.gap / dt : (overlap > 0.0 ? kPushFraction * overlap / dt : 0.0);
      const double old_n = c.lambda_n;
      c.lambda_n = std::max(0.0, old_n + c.mass_n * (target - vn));
      const double dn = c.lambda_n - old_n;
      if (dn != 0.0) applyImpulse(c, dn * c.n);
      if (config_.friction <= 0.0) continue;
      // Friction: stop the tangential sliding, within mu times the normal impulse.
      const Vec3d v2 = pointVelocity(c, true) - pointVelocity(c, false);
      const Vec3d vt = v2 - v2.dot(c.n) * c.n;
      const double vt_norm = vt.norm();
      if (vt_norm < 1e-12 && c.lambda_t.isZero(0)) continue;
      const Vec3d t = vt_norm > 1e-12 ? Vec3d(vt / vt_norm) : Vec3d(c.lambda_t.normalized());
      Body& a = bodies[c.a];
      double k_inv = 1.0 / a.mass + t.dot((inv_i[c.a] * c.ra.cross(t)).cross(c.ra));
      if (c.b >= 0)
      {
        const Body& b = bodies[std::size_t(c.b)];
        k_inv += 1.0 / b.mass + t.dot((inv_i[std::size_t(c.b)] * c.rb.cross(t)).cross(c.rb));
      }
      const Vec3d old_t = c.lambda_t;
      Vec3d next = old_t - (vt_norm / k_inv) * t;
      const double limit = config_.friction * c.lambda_n;
      if (next.norm() > limit) next *= limit / next.norm();
      const Vec3d dt_imp = next - old_t;
      c.lambda_t = next;
      if (!dt_imp.isZero(0)) applyImpulse(c, dt_imp);
    }
}

// ------------------------------------------------------------------------------ free bodies

std::string BodySet::stepFree(double dt, const Vec3d& gravity, ContactResolver& contacts)
{
  if (!has_free_) return "";
  std::vector<Vec3d> v_old, w_old;
  for (Body& body : bodies_)
  {
    v_old.push_back(body.v_com);
    w_old.push_back(body.omega);
    if (!body.free) continue;
    // Eq. A24: the fluid's force of the step (Eq. A12) and gravity; the fluid's torque about the
    // origin moved to the centre of mass, tau_c = tau_o - (c - o) x F.
    const Vec3d c = body.centerOfMass();
    const Vec3d torque_com = body.torque - (c - body.pose.translation).cross(body.force);  // N m
    body.v_com += dt * (body.force / body.mass + gravity);
    // Eq. A25: I dw/dt = tau - w x (I w), in world axes at the step's start.
    const Mat3d R = body.pose.rotation.toRotationMatrix();
    const Mat3d inertia = R * body.inertia_local * R.transpose();
    body.omega += dt * inertia.inverse() * (torque_com - body.omega.cross(inertia * body.omega));
  }
  // A blow-up of the fluid reaches a free body as a non-finite wrench; name it before contacts.
  const auto finite = [](const Body& b) { return b.v_com.allFinite() && b.omega.allFinite(); };
  std::string fault;
  for (const Body& body : bodies_)
    if (body.free && fault.empty() && !finite(body))
      fault = "free body '" + body.config.name + "': non-finite velocity from the fluid's wrench (force " +
              vecText(body.force) + " N, torque " + vecText(body.torque) + " N m)";
  // Eq. A26 (particles) or A26b (Bullet): contacts change the new velocities before the positions
  // move with them.
  contacts.apply(*this, dt);
  for (const Body& body : bodies_)
    if (body.free && fault.empty() && !finite(body))
      fault = "free body '" + body.config.name + "': non-finite velocity from the contacts (contact force " +
              vecText(body.contact_force) + " N)";
  for (std::size_t k = 0; k < bodies_.size(); ++k)
  {
    Body& body = bodies_[k];
    if (!body.free || !finite(body)) continue;  // left at its pose; the step is reported unstable
    // Positions with the new velocities (symplectic Euler, as the fluid's Eq. A16): the centre of
    // mass moves by dt v, the orientation turns by dt omega about it.
    const Vec3d c = body.centerOfMass() + dt * body.v_com;
    const double angle = body.omega.norm() * dt;  // rad
    if (angle > 0.0)
      body.pose.rotation =
          (Eigen::Quaterniond(Eigen::AngleAxisd(angle, body.omega.normalized())) * body.pose.rotation).normalized();
    body.pose.translation = c - body.pose.rotation * body.com_local;
    // Accelerations over the step, for the extrapolations' hydrostatic term (Eq. 3).
    const Vec3d a_com = (body.v_com - v_old[k]) / dt;
    body.alpha = (body.omega - w_old[k]) / dt;
    const Vec3d arm = body.pose.translation - c;
    body.a_origin = a_com + body.alpha.cross(arm) + body.omega.cross(body.omega.cross(arm));
    pose(body, 0.0, true);  // its particles at t + dt, with the new velocities
  }
  return fault;
}

}  // namespace fluid_sim
