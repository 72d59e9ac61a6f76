#include "fluid_sim/core/scene_config.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <sstream>

#include <Eigen/Eigenvalues>

#include "fluid_sim/core/boundary_sampling.h"

namespace fluid_sim
{
const char* toString(BoundaryPressureMethod method)
{
  switch (method)
  {
    case BoundaryPressureMethod::Mirroring:
      return "mirroring";
    case BoundaryPressureMethod::MirroringEq2:
      return "mirroring_eq2";
    case BoundaryPressureMethod::SphExtrapolation:
      return "sph";
    case BoundaryPressureMethod::Mls:
      return "mls";
  }
  return "?";
}

BoundaryPressureMethod parseBoundaryPressureMethod(const std::string& name, const std::string& key)
{
  if (name == "mirroring") return BoundaryPressureMethod::Mirroring;
  if (name == "mirroring_eq2") return BoundaryPressureMethod::MirroringEq2;
  if (name == "sph") return BoundaryPressureMethod::SphExtrapolation;
  if (name == "mls") return BoundaryPressureMethod::Mls;
  throw ConfigError(key,
                    "unknown boundary pressure method '" + name + "' (expected mirroring, mirroring_eq2, sph or mls)");
}

const char* toString(MlsSingularMode mode)
{
  switch (mode)
  {
    case MlsSingularMode::Fallback:
      return "fallback";
    case MlsSingularMode::PseudoInverse:
      return "pseudo_inverse";
    case MlsSingularMode::Regularized:
      return "regularized";
  }
  return "?";
}

const char* toString(SweepOrder order)
{
  return order == SweepOrder::GaussSeidel ? "gauss_seidel" : "jacobi";
}

const char* toString(ColdStart start)
{
  return start == ColdStart::Jacobi ? "jacobi" : "zero";
}

const char* toString(WarmStartGuess guess)
{
  return guess == WarmStartGuess::Damped ? "damped" : "previous";
}

const char* toString(ContactModel model)
{
  return model == ContactModel::Bullet ? "bullet" : "particles";
}

const char* toString(ViscosityModel model)
{
  switch (model)
  {
    case ViscosityModel::None:
      return "none";
    case ViscosityModel::Artificial:
      return "artificial";
    case ViscosityModel::Xsph:
      return "xsph";
  }
  return "?";
}

std::string numberText(double v)
{
  std::ostringstream os;
  os << v;
  return os.str();
}

std::string vectorText(const Vec3d& v)
{
  return "(" + numberText(v.x()) + ", " + numberText(v.y()) + ", " + numberText(v.z()) + ")";
}

namespace
{
constexpr double kMinTimeStep = 1e-7;  // s
constexpr double kMaxTimeStep = 1.0;   // s
// A fixed step is not shortened by the CFL condition: at 0.1 s gravity alone moves a particle
// g dt^2 = 0.1 m per step, several spacings in any scene.
constexpr double kMaxFixedTimeStep = 0.1;  // s
constexpr int kMaxSolverIterations = 10000;

std::string str(double v)
{
  return numberText(v);
}

void requireFinite(const Vec3d& v, const std::string& key)
{
  if (!v.allFinite()) throw ConfigError(key, "must be finite");
}

void requirePositive(double v, const std::string& key)
{
  if (!(v > 0.0) || !std::isfinite(v)) throw ConfigError(key, "must be > 0, got " + str(v));
}

void requireNonNegative(double v, const std::string& key)
{
  if (!(v >= 0.0) || !std::isfinite(v)) throw ConfigError(key, "must be >= 0, got " + str(v));
}

void requireBox(const AxisBox& box, const std::string& key)
{
  requireFinite(box.min, key + ".min");
  requireFinite(box.max, key + ".max");
  for (int k = 0; k < 3; ++k)
    if (!(box.max[k] > box.min[k]))
      throw ConfigError(key, "max must exceed min on every axis (axis " + std::to_string(k) + ": min " +
                                 str(box.min[k]) + ", max " + str(box.max[k]) + ")");
}

/// An explicit-particle block: no box or velocity beside the particles, one velocity per
/// position, at least one particle, every value finite. Particles outside the domain are not an
/// error: the fill drops and counts them, as the step does with those that leave it.
void requireParticles(const FluidBlockConfig& block, const std::string& key)
{
  if (!block.box.min.isZero(0) || !block.box.max.isZero(0) || !block.velocity.isZero(0))
    throw ConfigError(key, "a fluid block is either a box (with a velocity) or particles, not both");
  const ExplicitParticles& p = *block.particles;
  const std::string pkey = key + ".particles";
  if (p.velocities.size() != p.positions.size())
    throw ConfigError(pkey, std::to_string(p.positions.size()) + " positions but " +
                                std::to_string(p.velocities.size()) + " velocities");
  if (p.positions.empty()) throw ConfigError(pkey, "holds no particle");
  for (std::size_t k = 0; k < p.positions.size(); ++k)
  {
    if (!p.positions[k].allFinite())
      throw ConfigError(pkey, "particle " + std::to_string(k) + " has a non-finite position");
    if (!p.velocities[k].allFinite())
      throw ConfigError(pkey, "particle " + std::to_string(k) + " has a non-finite velocity");
  }
}

/// A ROS base name: an ASCII letter, then ASCII letters, digits or '_' (instrument names become
/// topic names and CSV fields as they are; the node's sanitiser is for names it cannot choose).
bool isRosBaseName(const std::string& name)
{
  if (name.empty() || !std::isalpha(static_cast<unsigned char>(name[0]))) return false;
  for (char c : name)
  {
    const auto u = static_cast<unsigned char>(c);
    if (u >= 0x80 || !(std::isalnum(u) || c == '_')) return false;
  }
  return true;
}

/// An instrument's name: a ROS base name, not used by an earlier entry of the same list.
template <class Config>
void requireInstrumentName(const std::vector<Config>& list, std::size_t i, const std::string& key)
{
  const std::string& name = list[i].name;
  if (name.empty()) throw ConfigError(key + ".name", "must not be empty");
  if (!isRosBaseName(name))
    throw ConfigError(key + ".name", "'" + name +
                                         "' is no valid ROS name (an ASCII letter, then letters, digits or '_'): "
                                         "it becomes a topic name");
  for (std::size_t j = 0; j < i; ++j)
    if (list[j].name == name) throw ConfigError(key + ".name", "duplicate name '" + name + "'");
}

/// A region's or a sink's box (with its pose) or sphere; a body's inside is checked by the caller.
void requireRegionShape(const RegionConfig& r, const std::string& key)
{
  if (r.shape == RegionShape::Box)
  {
    requireBox(r.box, key + ".box");
    requireFinite(r.pose.translation, key + ".pose.xyz");
    if (!r.pose.rotation.coeffs().allFinite()) throw ConfigError(key + ".pose.rpy", "must be finite");
  }
  else if (r.shape == RegionShape::Sphere)
  {
    requireFinite(r.sphere.center, key + ".sphere.center");
    requirePositive(r.sphere.radius, key + ".sphere.radius");
  }
}

void validateInstruments(const SceneConfig& s)
{
  for (std::size_t i = 0; i < s.regions.size(); ++i)
  {
    const RegionConfig& r = s.regions[i];
    const std::string key = "regions[" + std::to_string(i) + "]";
    requireInstrumentName(s.regions, i, key);
    requireRegionShape(r, key);
    if (r.shape == RegionShape::Body && r.body.empty()) throw ConfigError(key + ".body", "must name a boundary body");
  }
  for (std::size_t i = 0; i < s.sinks.size(); ++i)
  {
    const RegionConfig& r = s.sinks[i];
    const std::string key = "sinks[" + std::to_string(i) + "]";
    requireInstrumentName(s.sinks, i, key);
    if (r.shape == RegionShape::Body)
      throw ConfigError(key + ".body", "a sink is a box or a sphere, not a body's inside");
    requireRegionShape(r, key);
  }
  for (std::size_t i = 0; i < s.probes.size(); ++i)
  {
    const std::string key = "probes[" + std::to_string(i) + "]";
    requireInstrumentName(s.probes, i, key);
    requireFinite(s.probes[i].position, key + ".position");
  }
  for (std::size_t i = 0; i < s.emitters.size(); ++i)
  {
    const EmitterConfig& e = s.emitters[i];
    const std::string key = "emitters[" + std::to_string(i) + "]";
    requireInstrumentName(s.emitters, i, key);
    if (e.shape == NozzleShape::Circle)
      requirePositive(e.radius, key + ".circle.radius");
    else if (!(e.size.allFinite() && e.size.x() > 0.0 && e.size.y() > 0.0))
      throw ConfigError(key + ".rectangle.size", "must be two finite lengths > 0 (m)");
    requireFinite(e.pose.translation, key + ".pose.xyz");
    if (!e.pose.rotation.coeffs().allFinite()) throw ConfigError(key + ".pose.rpy", "must be finite");
    const bool has_speed = e.speed != 0.0, has_rate = e.flow_rate != 0.0;
    if (has_speed == has_rate)
      throw ConfigError(key, has_speed ? "has both speed and flow_rate; give one (the other follows from the nozzle)"
                                       : "needs a speed (m/s) or a flow_rate (m^3/s)");
    if (has_speed) requirePositive(e.speed, key + ".speed");
    if (has_rate) requirePositive(e.flow_rate, key + ".flow_rate");
    requireNonNegative(e.start, key + ".start");
    if (!(e.duration > 0.0)) throw ConfigError(key + ".duration", "must be > 0 (s), got " + str(e.duration));
    if (!e.frame.empty() && !e.body.empty()) throw ConfigError(key + ".frame", "give either body or frame, not both");
  }
  if (!std::isfinite(s.contacts.friction) || s.contacts.friction < 0.0)
    throw ConfigError("contacts.friction", "must be finite and >= 0, got " + str(s.contacts.friction));
  if (!std::isfinite(s.contacts.rolling_resistance) || s.contacts.rolling_resistance < 0.0)
    throw ConfigError("contacts.rolling_resistance",
                      "must be finite and >= 0, got " + str(s.contacts.rolling_resistance));
  if (s.contacts.model != ContactModel::Bullet && s.contacts.model != ContactModel::Particles)
    throw ConfigError("contacts.model", "must be bullet or particles");
  if (s.spill.enabled && !std::isfinite(s.spill.below))
    throw ConfigError("spill.below", "must be finite, got " + str(s.spill.below));
}

/// A free body's `dynamic` entry (key: its dotted scene key).
void validateDynamic(const BoundaryConfig& b, const std::string& key)
{
  const DynamicConfig& d = b.dynamic;
  if (b.inside)
    throw ConfigError(key, "'" + b.name + "' is a container (inside: true); a container cannot be a free body");
  if (b.externally_posed)
    throw ConfigError(key, "'" + b.name + "' is posed from outside (external); it cannot also be free");
  if (!b.motion.isStatic()) throw ConfigError(key, "'" + b.name + "' has a scripted motion; it cannot also be free");
  if (!std::isfinite(d.density) || !std::isfinite(d.mass) || d.density < 0.0 || d.mass < 0.0)
    throw ConfigError(key, "density and mass must be finite and positive, got density " + str(d.density) +
                               " kg/m^3, mass " + str(d.mass) + " kg");
  if ((d.density > 0.0) == (d.mass > 0.0))
    throw ConfigError(key, "give exactly one of density (kg/m^3) and mass (kg), > 0, for '" + b.name +
                               "', got density " + str(d.density) + ", mass " + str(d.mass));
  if (b.type == ShapeType::Mesh && !b.mesh_closed && (!(d.mass > 0.0) || !d.inertia || !d.center_of_mass))
    throw ConfigError(key, "'" + b.name +
                               "' is an open mesh, which has no volume: give mass (kg), inertia (kg m^2, about the "
                               "centre of mass) and center_of_mass (m, body frame)");
  if (d.inertia)
  {
    const std::array<double, 6>& i = *d.inertia;
    Mat3d m;
    m << i[0], i[3], i[4], i[3], i[1], i[5], i[4], i[5], i[2];
    if (!m.allFinite()) throw ConfigError(key + ".inertia", "must be finite");
    // A physical inertia is positive definite (and its principal moments obey the triangle
    // inequality, which follows for any real mass distribution).
    const Eigen::SelfAdjointEigenSolver<Mat3d> eig(m);
    const Vec3d l = eig.eigenvalues();  // ascending
    if (!(l(0) > 0.0) || l(0) + l(1) < l(2) * (1.0 - 1e-9))
      throw ConfigError(key + ".inertia", "is not a physical inertia (principal moments " + str(l(0)) + ", " +
                                              str(l(1)) + ", " + str(l(2)) +
                                              " kg m^2: each must be positive and at most the sum of "
                                              "the other two)");
  }
  if (d.center_of_mass) requireFinite(*d.center_of_mass, key + ".center_of_mass");
  requireFinite(d.linear_velocity, key + ".linear_velocity");
  requireFinite(d.angular_velocity, key + ".angular_velocity");
}

bool boxInside(const AxisBox& inner, const AxisBox& outer)
{
  return (inner.min.array() >= outer.min.array()).all() && (inner.max.array() <= outer.max.array()).all();
}
}  // namespace

bool canMove(const BoundaryConfig& b)
{
  return b.externally_posed || b.dynamic.enabled || b.motion.linear_velocity != Vec3d::Zero() ||
         b.motion.angular_velocity != Vec3d::Zero();
}

double sampleSpacing(const BoundaryConfig& b, double spacing)
{
  if (b.sample_spacing > 0.0) return b.sample_spacing;
  if (b.sample_spacing == kAutoSampleSpacing && canMove(b)) return 0.5 * spacing;
  return spacing;
}

AxisBox boundsOf(const std::vector<Vec3d>& points)
{
  AxisBox box;
  if (points.empty()) return box;
  box.min = box.max = points.front();
  for (const Vec3d& p : points)
  {
    box.min = box.min.cwiseMin(p);
    box.max = box.max.cwiseMax(p);
  }
  return box;
}

namespace
{
constexpr double kSpeedOfSoundInWater = 1480.0;  // m/s, at 20 degrees C

/// The farthest a point of the body's shape, at its pose at t = 0, lies from `point` (m, world):
/// over its bounding box's corners (a bound, not exact, for a sphere or cylinder).
double farthestFrom(const BoundaryConfig& b, const Vec3d& point)
{
  Vec3d lo, hi;
  switch (b.type)
  {
    case ShapeType::Box:
      lo = b.box.min;
      hi = b.box.max;
      break;
    case ShapeType::Sphere:
      lo = b.sphere.center - Vec3d::Constant(b.sphere.radius);
      hi = b.sphere.center + Vec3d::Constant(b.sphere.radius);
      break;
    case ShapeType::Cylinder:
    {
      const double r = std::hypot(b.cylinder.radius, 0.5 * b.cylinder.length);
      lo = b.cylinder.center - Vec3d::Constant(r);
      hi = b.cylinder.center + Vec3d::Constant(r);
      break;
    }
    case ShapeType::Mesh:
    {
      const AxisBox bounds = boundsOf(b.mesh.vertices);
      lo = bounds.min;
      hi = bounds.max;
      break;
    }
  }
  double farthest = 0.0;
  for (int k = 0; k < 8; ++k)
  {
    const Vec3d corner((k & 1) ? hi.x() : lo.x(), (k & 2) ? hi.y() : lo.y(), (k & 4) ? hi.z() : lo.z());
    farthest = std::max(farthest, (b.pose.apply(corner) - point).norm());
  }
  return farthest;
}
}  // namespace

std::string boundaryKey(const BoundaryConfig& b, std::size_t index)
{
  return b.key.empty() ? "boundaries[" + std::to_string(index) + "]" : b.key;
}

std::string dynamicKey(const BoundaryConfig& b, std::size_t index)
{
  return b.dynamic_key.empty() ? boundaryKey(b, index) + ".dynamic" : b.dynamic_key;
}

void validate(const SceneConfig& s)
{
  requirePositive(s.spacing, "spacing");
  requirePositive(s.rest_density, "rest_density");
  requireFinite(s.gravity, "gravity");
  requireBox(s.domain, "domain");
  const Vec3d extent = s.domain.max - s.domain.min;
  // A dense grid of cells of the kernel support covers the domain; refuse absurd sizes early.
  const double cells = (extent / (2.0 * s.spacing)).array().ceil().prod();
  if (cells > 2.0e8)
    throw ConfigError("domain", "too large for spacing " + str(s.spacing) + " (" + str(cells) +
                                    " grid cells); shrink the domain or enlarge the spacing");

  const TimeStepConfig& ts = s.time_step;
  if (ts.adaptive)
  {
    requirePositive(ts.cfl, "time_step.cfl");
    if (ts.cfl > 2.0) throw ConfigError("time_step.cfl", "must be <= 2, got " + str(ts.cfl));
    requirePositive(ts.min, "time_step.min");
    requirePositive(ts.max, "time_step.max");
    if (ts.min > ts.max) throw ConfigError("time_step.min", "must not exceed time_step.max");
    // Below 1e-7 s a run makes no progress (10 million steps per simulated second); above 1 s
    // nothing about a CFL step is left.
    if (ts.min < kMinTimeStep || ts.min > kMaxTimeStep)
      throw ConfigError("time_step.min",
                        "must be in [" + str(kMinTimeStep) + ", " + str(kMaxTimeStep) + "] s, got " + str(ts.min));
    if (ts.max > kMaxTimeStep)
      throw ConfigError("time_step.max", "must be <= " + str(kMaxTimeStep) + " s, got " + str(ts.max));
  }
  else
  {
    requirePositive(ts.fixed, "time_step.fixed");
    if (ts.fixed < kMinTimeStep || ts.fixed > kMaxFixedTimeStep)
      throw ConfigError("time_step.fixed", "must be in [" + str(kMinTimeStep) + ", " + str(kMaxFixedTimeStep) +
                                               "] s, got " + str(ts.fixed));
  }

  const SolverConfig& sv = s.solver;
  requirePositive(sv.density_error, "solver.density_error");
  requirePositive(sv.divergence_error, "solver.divergence_error");
  if (sv.min_iterations < 0)
    throw ConfigError("solver.min_iterations", "must be >= 0, got " + std::to_string(sv.min_iterations));
  if (sv.max_iterations < 1)
    throw ConfigError("solver.max_iterations", "must be >= 1, got " + std::to_string(sv.max_iterations));
  // Each iteration is two passes over every neighbour pair: more than this is a hang, not a
  // tolerance (the density solve converges in 2-10 iterations in every shipped scene).
  if (sv.max_iterations > kMaxSolverIterations)
    throw ConfigError("solver.max_iterations", "must be <= " + std::to_string(kMaxSolverIterations) + ", got " +
                                                   std::to_string(sv.max_iterations));
  if (sv.min_iterations > kMaxSolverIterations)
    throw ConfigError("solver.min_iterations", "must be <= " + std::to_string(kMaxSolverIterations) + ", got " +
                                                   std::to_string(sv.min_iterations));
  if (sv.min_iterations > sv.max_iterations)
    throw ConfigError("solver.min_iterations", "must not exceed solver.max_iterations");
  if (sv.min_divergence_iterations < 0 || sv.min_divergence_iterations > sv.max_iterations)
    throw ConfigError("solver.min_divergence_iterations", "must be in [0, solver.max_iterations]");
  if (!(sv.omega > 0.0 && sv.omega <= 1.0))
    throw ConfigError("solver.omega", "must be in (0, 1], got " + str(sv.omega));
  if (!(sv.wall_guard >= 0.0 && sv.wall_guard <= 1.0))
    throw ConfigError("solver.wall_guard", "must be in [0, 1] spacings (0 = off), got " + str(sv.wall_guard));
  if (!(sv.chebyshev_rho >= 0.0 && sv.chebyshev_rho < 1.0))
    throw ConfigError("solver.chebyshev_rho", "must be in [0, 1) (0 = off), got " + str(sv.chebyshev_rho));
  if (sv.chebyshev_rho > 0.0 && sv.sweep == SweepOrder::GaussSeidel)
    throw ConfigError(
        "solver.chebyshev_rho",
        "extrapolates Jacobi sweeps (Eq. A8a) and cannot be combined with solver.sweep: gauss_seidel; got " +
            str(sv.chebyshev_rho));
  if (sv.chebyshev_delay < 1 || sv.chebyshev_delay > kMaxSolverIterations)
    throw ConfigError("solver.chebyshev_delay", "must be in [1, " + std::to_string(kMaxSolverIterations) + "], got " +
                                                    std::to_string(sv.chebyshev_delay));
  if (!(sv.mls_fit_radius >= 1.0 && sv.mls_fit_radius <= 4.0))
    throw ConfigError("solver.mls_fit_radius", "must be in [1, 4] spacings, got " + str(sv.mls_fit_radius));
  if (!(sv.mls_eigen_tolerance > 0.0 && sv.mls_eigen_tolerance < 1.0))
    throw ConfigError("solver.mls_eigen_tolerance", "must be in (0, 1), got " + str(sv.mls_eigen_tolerance));

  requireNonNegative(s.viscosity.coefficient, "viscosity.coefficient");
  requireNonNegative(s.viscosity.boundary, "viscosity.boundary");
  if (s.viscosity.model == ViscosityModel::Xsph)
  {
    // XSPH blends a particle's velocity towards its neighbours' mean: past 1 it overshoots.
    if (s.viscosity.coefficient > 1.0)
      throw ConfigError("viscosity.coefficient", "XSPH coefficients must be <= 1, got " + str(s.viscosity.coefficient));
    if (s.viscosity.boundary > 1.0)
      throw ConfigError("viscosity.boundary", "XSPH coefficients must be <= 1, got " + str(s.viscosity.boundary));
  }

  requirePositive(s.stability.max_density_error, "stability.max_density_error");
  requirePositive(s.stability.max_cfl, "stability.max_cfl");
  // A step chosen at cfl spacings for the speed at its start ends faster (gravity alone adds
  // g dt): at cfl >= max_cfl the stability check called healthy free-falling water unstable in
  // its first steps after the speed had grown.
  if (ts.adaptive && ts.cfl >= s.stability.max_cfl)
    throw ConfigError("time_step.cfl", "must be below stability.max_cfl (" + str(s.stability.max_cfl) + "), got " +
                                           str(ts.cfl) +
                                           ": the speed grows within a step, and the stability check would call "
                                           "such a step unstable");
  requireNonNegative(s.output.frame_interval, "output.frame_interval");
  requireNonNegative(s.duration, "duration");
  if (s.max_boundary_particles < 1) throw ConfigError("max_boundary_particles", "must be >= 1");
  if (s.max_fluid_particles < 1) throw ConfigError("max_fluid_particles", "must be >= 1");
  validateInstruments(s);

  if (s.fluid.empty() && s.emitters.empty())
    throw ConfigError("fluid", "the scene has no fluid block (and no emitter that would bring water)");
  for (std::size_t i = 0; i < s.fluid.size(); ++i)
  {
    const std::string key = "fluid[" + std::to_string(i) + "]";
    if (s.fluid[i].particles)
    {
      requireParticles(s.fluid[i], key);
      continue;
    }
    requireBox(s.fluid[i].box, key + ".box");
    requireFinite(s.fluid[i].velocity, key + ".velocity");
    if (!(s.fluid[i].velocity.norm() <= kSpeedOfSoundInWater))  // 1e30 m/s ran and blew up in the first step
      throw ConfigError(key + ".velocity", "speed " + str(s.fluid[i].velocity.norm()) +
                                               " m/s is faster than sound in water (" + str(kSpeedOfSoundInWater) +
                                               " m/s)");
    if (!boxInside(s.fluid[i].box, s.domain))
      throw ConfigError(key + ".box", "fluid block lies (partly) outside the domain");
  }
  // The particle budget, before the fill allocates anything (the domain check alone allows
  // about 1.6e9 lattice points). Counted as the fill counts its lattice (fluid_fill.cpp).
  double fluid_particles = 0.0;
  for (const FluidBlockConfig& block : s.fluid)
  {
    if (block.particles)
    {
      fluid_particles += double(block.particles->positions.size());
      continue;
    }
    double n = 1.0;
    for (int a = 0; a < 3; ++a)
      n *= std::max(1.0, std::floor((block.box.max[a] - block.box.min[a]) / s.spacing + 1e-6));
    fluid_particles += n;
  }
  if (fluid_particles > double(s.max_fluid_particles))
    throw ConfigError("fluid", "the blocks make " + str(fluid_particles) + " fluid particles at spacing " +
                                   str(s.spacing) +
                                   " m, more than max_fluid_particles = " + std::to_string(s.max_fluid_particles) +
                                   "; enlarge the spacing, shrink the blocks or raise max_fluid_particles");

  // fill.relax_tolerance is a relative density error (Eq. A23): at 0 no lattice could meet it, at
  // 1 or more it would never relax anything.
  if (!(s.fill.relax_tolerance > 0.0 && s.fill.relax_tolerance < 1.0))
    throw ConfigError("fill.relax_tolerance", "must be in (0, 1), got " + str(s.fill.relax_tolerance));
  if (s.fill.relax_max_steps < 0 || s.fill.relax_max_steps > 10000)
    throw ConfigError("fill.relax_max_steps", "must be in [0, 10000], got " + std::to_string(s.fill.relax_max_steps));

  for (std::size_t i = 0; i < s.boundaries.size(); ++i)
  {
    const BoundaryConfig& b = s.boundaries[i];
    const std::string key = boundaryKey(b, i);
    if (b.name.empty()) throw ConfigError(key + ".name", "must not be empty");
    for (std::size_t j = 0; j < i; ++j)
      if (s.boundaries[j].name == b.name) throw ConfigError(key + ".name", "duplicate boundary name '" + b.name + "'");
    switch (b.type)
    {
      case ShapeType::Box:
        requireBox(b.box, key + ".box");
        break;
      case ShapeType::Sphere:
        requireFinite(b.sphere.center, key + ".sphere.center");
        requirePositive(b.sphere.radius, key + ".sphere.radius");
        break;
      case ShapeType::Cylinder:
        requireFinite(b.cylinder.center, key + ".cylinder.center");
        requireFinite(b.cylinder.axis, key + ".cylinder.axis");
        if (b.cylinder.axis.norm() < 1e-12) throw ConfigError(key + ".cylinder.axis", "must not be zero");
        requirePositive(b.cylinder.radius, key + ".cylinder.radius");
        requirePositive(b.cylinder.length, key + ".cylinder.length");
        break;
      case ShapeType::Mesh:
        if (b.mesh.triangles.empty()) throw ConfigError(key + ".mesh", "mesh of '" + b.name + "' has no triangles");
        for (const auto& v : b.mesh.vertices)
          if (!v.allFinite()) throw ConfigError(key + ".mesh", "mesh of '" + b.name + "' has a NaN or infinite vertex");
        for (const auto& t : b.mesh.triangles)
          for (int k : t)
            if (k < 0 || k >= static_cast<int>(b.mesh.vertices.size()))
              throw ConfigError(key + ".mesh", "mesh of '" + b.name + "' has a triangle index out of range");
        break;
    }
    requireFinite(b.pose.translation, key + ".pose.xyz");
    if (!b.pose.rotation.coeffs().allFinite()) throw ConfigError(key + ".pose.rpy", "must be finite");
    requireFinite(b.motion.angular_velocity, key + ".motion.angular_velocity");
    requireFinite(b.motion.about, key + ".motion.about");
    requireFinite(b.motion.linear_velocity, key + ".motion.linear_velocity");
    requireNonNegative(b.motion.start, key + ".motion.start");
    requireNonNegative(b.motion.ramp, key + ".motion.ramp");
    // A stop (default: none) comes after the start and leaves room for both ramps.
    if (std::isnan(b.motion.stop) || b.motion.stop < b.motion.start + 2.0 * b.motion.ramp ||
        (b.motion.ramp == 0.0 && !(b.motion.stop > b.motion.start)))
      throw ConfigError(key + ".motion.stop", "must be at least start + 2 ramp (" + str(b.motion.start) + " + 2 x " +
                                                  str(b.motion.ramp) + " s: a ramp up, then one down), got " +
                                                  str(b.motion.stop));
    // Beyond the speed of sound in water (1,480 m/s) an incompressible model means nothing, and
    // such values are typing slips: an angular velocity of 1e300 rad/s overflowed the float
    // particle velocities and the body dropped out of the water without a word.
    const double surface_speed =
        b.motion.linear_velocity.norm() + b.motion.angular_velocity.norm() * farthestFrom(b, b.motion.about);  // m/s
    if (!(surface_speed <= kSpeedOfSoundInWater))
      throw ConfigError(key + ".motion", "'" + b.name + "' would move at up to " + str(surface_speed) +
                                             " m/s (linear_velocity plus angular_velocity times its reach from "
                                             "about), faster than sound in water (" +
                                             str(kSpeedOfSoundInWater) + " m/s)");
    // A body posed from outside follows its poses only: a motion beside it was ignored without a
    // word (the plate stood still where the script would have pulled it).
    if (b.externally_posed && !b.motion.isStatic())
      throw ConfigError(key + ".motion", "'" + b.name +
                                             "' is posed from outside (external: true); it cannot also have a "
                                             "scripted motion: give one or the other");
    if (b.dynamic.enabled) validateDynamic(b, dynamicKey(b, i));
    if (b.sample_spacing != kAutoSampleSpacing) requireNonNegative(b.sample_spacing, key + ".sample_spacing");
    if (b.sample_spacing > s.spacing)
      throw ConfigError(key + ".sample_spacing", "must not exceed the scene spacing " + str(s.spacing));
    // Refuse a body too large for its spacing before anything is sampled.
    const double ss = sampleSpacing(b, s.spacing);  // m
    const double estimate = estimateBoundaryParticles(b, ss, s.spacing);
    if (!(estimate <= double(s.max_boundary_particles)))
      throw ConfigError(key, "'" + b.name + "' would need about " + estimateText(estimate) +
                                 " boundary particles at sample spacing " + str(ss) +
                                 " m, more than max_boundary_particles = " + std::to_string(s.max_boundary_particles) +
                                 "; use a coarser spacing or sample_spacing, a smaller body, or raise "
                                 "max_boundary_particles");
  }
}

}  // namespace fluid_sim
