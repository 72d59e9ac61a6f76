#pragma once
// The scene as plain data: what the YAML file (io) or the ROS parameters fill in and what
// Simulation is built from. Every field documents its scene key and unit. validate() checks
// ranges and consistency and throws ConfigError naming the key.

#include <array>
#include <cstddef>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fluid_sim/core/types.h"

namespace fluid_sim
{
enum class BoundaryPressureMethod
{
  Mirroring,         // the wall's density constraint alone: p_b = 0 in Eq. 1 (Akinci's single term)
  MirroringEq2,      // Akinci 2012 as the paper writes it: p_b := p_f (paper Eq. 2)
  SphExtrapolation,  // Adami 2012 (paper Eq. 3)
  Mls                // the paper's MLS extrapolation (Eqs. 7-16)
};

/// "mirroring" | "mirroring_eq2" | "sph" | "mls"
const char* toString(BoundaryPressureMethod method);
/// Throws ConfigError(key, ...) for an unknown name.
BoundaryPressureMethod parseBoundaryPressureMethod(const std::string& name, const std::string& key);

/// How MLS treats a (nearly) singular moment matrix M_b (docs/method.md, MLS).
enum class MlsSingularMode
{
  Fallback,       // Eq. 16: p_b = alpha_b whenever the smallest eigenvalue ratio is below the tolerance
  PseudoInverse,  // drop only the weak directions; keep the observable slopes
  Regularized     // every direction, damped smoothly by its eigenvalue: lambda / (lambda^2 + (tol lambda_max)^2)
};
const char* toString(MlsSingularMode mode);

/// The first guess of a solve without solver.warm_start (docs/method.md, Eq. A10).
enum class ColdStart
{
  Zero,   // p_i = 0 (the paper's start, the default; the first sweep needs no pass over the pairs)
  Jacobi  // one unrelaxed Jacobi step from zero where the water is compressed: p_i = s_i / A_i
};
const char* toString(ColdStart start);

/// The order of the density solve's pressure updates (docs/method.md, Eqs. A8, A8b).
enum class SweepOrder
{
  Jacobi,      // every particle from the last sweep's a^p, relaxed by solver.omega (Eq. A8, the paper's)
  GaussSeidel  // in turn, each from the a^p its predecessors left (Eq. A8b)
};
const char* toString(SweepOrder order);

/// The first guess of a solve with solver.warm_start (docs/method.md, Eq. A10b).
enum class WarmStartGuess
{
  Previous,  // the previous step's pressure where Eq. A10 holds (the default)
  Damped     // half of it plus the cold start's Jacobi step there: still water holds still
};
const char* toString(WarmStartGuess guess);

struct AxisBox
{
  Vec3d min = Vec3d::Zero();  // m
  Vec3d max = Vec3d::Zero();  // m

  /// Whether p (m) lies in [min, max], faces included.
  bool contains(const Vec3d& p) const
  {
    return (p.array() >= min.array()).all() && (p.array() <= max.array()).all();
  }
};

/// The smallest axis-aligned box holding `points` (m); a zero box when there are none.
AxisBox boundsOf(const std::vector<Vec3d>& points);

struct SphereShape
{
  Vec3d center = Vec3d::Zero();  // m
  double radius = 0.0;           // m
};

/// A closed cylinder (side and both caps). `center` is the midpoint of its axis segment.
struct CylinderShape
{
  Vec3d center = Vec3d::Zero();  // m
  Vec3d axis = Vec3d::UnitZ();   // unit-less direction, normalised by validate()
  double radius = 0.0;           // m
  double length = 0.0;           // m, along axis
};

class MeshInsideIndex;  // mesh_inside_index.h

/// A triangle mesh in the body frame. Triangles index `vertices`.
struct TriangleMesh
{
  std::vector<Vec3d> vertices;                // m
  std::vector<std::array<int, 3>> triangles;  // vertex indices
  /// Optional acceleration of insideShape() for closed meshes, set by buildInsideIndex()
  /// (io sets it for every mesh it reads); ignored if the counts no longer match the mesh.
  std::shared_ptr<const MeshInsideIndex> inside_index;
};

enum class ShapeType
{
  Box,
  Sphere,
  Cylinder,
  Mesh
};

/// Scripted rigid motion: x(t) = about + R(angular_velocity * S(t)) (x(0) - about) + linear_velocity * S(t),
/// with S(t) = t by default. With a start time or a ramp, the velocities are r(t) times the
/// configured ones, r = 0 before `start`, rising smoothly to 1 over `ramp` seconds, and S(t) is the
/// integral of r (Eq. A17 of docs/method.md).
struct MotionConfig
{
  Vec3d angular_velocity = Vec3d::Zero();  // rad/s, world frame          key: motion.angular_velocity
  Vec3d about = Vec3d::Zero();             // m, a point on the axis       key: motion.about
  Vec3d linear_velocity = Vec3d::Zero();   // m/s                          key: motion.linear_velocity
  double start = 0.0;                      // s, still at the initial pose before it   key: motion.start
  double ramp = 0.0;                       // s, velocities rise from 0 over it        key: motion.ramp
  // s, the time the body is still again: the velocities fall to 0 over `ramp` ending here, and
  // it stays at the pose it reached. Infinite (the default): it never stops.    key: motion.stop
  double stop = std::numeric_limits<double>::infinity();
  bool isStatic() const
  {
    return angular_velocity.isZero(0) && linear_velocity.isZero(0);
  }
};

/// How a mesh surface is placed relative to its boundary-particle layer.
enum class SurfaceOffset
{
  Auto,  // half a spacing into the solid (or outside a container), like primitives
  None   // on the surface itself (thin-walled open shapes: a cup, a paddle)
};

/// A free rigid body (key `dynamic`): moved by gravity, the fluid's force and torque (the wall
/// force the wrenches report, Eq. A12) and contacts with other bodies (docs/method.md, Free
/// bodies). Mass, centre of mass and inertia follow from the closed shape and a uniform density
/// unless given; an open mesh has no volume and needs `mass` and `inertia`.
struct DynamicConfig
{
  bool enabled = false;  // the key is present
  double density = 0.0;  // kg/m^3, uniform                          key: dynamic.density
  double mass = 0.0;     // kg; exactly one of density and mass      key: dynamic.mass
  // kg m^2 about the centre of mass, body axes: ixx, iyy, izz, ixy, ixz, iyz (the products as
  // URDF writes them, I_xy = -sum m x y).                               key: dynamic.inertia
  std::optional<std::array<double, 6>> inertia;
  std::optional<Vec3d> center_of_mass;     // m, body frame              key: dynamic.center_of_mass
  Vec3d linear_velocity = Vec3d::Zero();   // m/s, world, of the centre of mass at t = 0
  Vec3d angular_velocity = Vec3d::Zero();  // rad/s, world, at t = 0
};

struct BoundaryConfig
{
  std::string name;  // key: name (default: shape type and index)
  ShapeType type = ShapeType::Box;
  AxisBox box;              // key: box {min, max}
  SphereShape sphere;       // key: sphere {center, radius}
  CylinderShape cylinder;   // key: cylinder {center, axis, radius, length}
  TriangleMesh mesh;        // filled by io from mesh files / URDF links
  bool mesh_closed = true;  // set by io: false for an open mesh (cup, paddle)
  SurfaceOffset mesh_offset = SurfaceOffset::Auto;
  bool inside = false;            // key: inside; true = a container (fluid stays inside)
  Pose pose;                      // body frame -> world at t = 0 (key: pose {xyz, rpy})
  MotionConfig motion;            // key: motion
  bool externally_posed = false;  // the caller poses it every step (ROS node through tf)
  // m, boundary particle spacing; 0 (the default): the scene spacing; kAutoSampleSpacing (key
  // value `auto`): see sampleSpacing(); may be finer, never coarser.          key: sample_spacing
  double sample_spacing = 0.0;
  DynamicConfig dynamic;  // key: dynamic (a free body)
  // Where the scene wrote it, for messages (set by io): the entry's key ("boundaries[1]"; a URDF
  // entry's links all share theirs), and where its `dynamic` is written when not at key.dynamic
  // (a free link: "boundaries[1].urdf.free_links.hull"). Empty: "boundaries[<index>]".
  std::string key;
  std::string dynamic_key;
};

/// The key messages name a body by: b.key, or "boundaries[index]" when io did not set one.
std::string boundaryKey(const BoundaryConfig& b, std::size_t index);
/// The key of a body's `dynamic` entry: b.dynamic_key, or boundaryKey() + ".dynamic".
std::string dynamicKey(const BoundaryConfig& b, std::size_t index);

/// `sample_spacing: auto`.
constexpr double kAutoSampleSpacing = -1.0;

/// Whether a body can move: scripted motion with a velocity, or posed by the caller every step.
bool canMove(const BoundaryConfig& b);

/// The spacing a body is sampled at, m. Given (> 0): that; 0: the scene's; auto: half the
/// scene's for a body that can move, the scene's for one that cannot. A wall sampled at the fluid
/// spacing is a row of bumps one spacing apart that the water's first layer sits between; a wall
/// that slides along the water drags it along by them (a cylinder turning under still water:
/// 10-30 % of solid-body rotation per second at R/s 10-20 for every boundary method; sampled at
/// half the spacing, below 0.2 %/s). Not the default: the finer layer's flat-layer volumes (Eq.
/// A3, derived at the fluid spacing) push 2 % less at a spacing's distance, and a submerged cube
/// feels 3-4 % less buoyancy (7 spacings a side), a 4-spacing cube 10 % less (docs/method_notes.md,
/// Turning container).
double sampleSpacing(const BoundaryConfig& b, double spacing);

/// Fluid particles given one by one instead of as a lattice: the state of an earlier run (key
/// particles {file: FILE}, a PLY frame the runner wrote). Each particle stands for the mass of a
/// lattice particle, rest_density * spacing^3, so the state must come from a run with the same
/// spacing and rest density.
struct ExplicitParticles
{
  std::vector<Vec3d> positions;   // m, world
  std::vector<Vec3d> velocities;  // m/s, one per position
};

/// One entry of `fluid`: a box filled on the spacing lattice, or explicit particles.
struct FluidBlockConfig
{
  AxisBox box;                     // key: box {min, max}, m
  Vec3d velocity = Vec3d::Zero();  // key: velocity, m/s (a box block only)
  /// key: particles {file}. When set, the block is these particles and box and velocity stay at
  /// their defaults (all zero).
  std::optional<ExplicitParticles> particles;
};

/// How the box blocks' lattices are made ready before t = 0, so that water in a curved or tilted
/// container starts at rest (docs/method.md, Initial fluid; Eqs. A21-A23). Neither touches the
/// explicit particles of a saved state, and neither changes a lattice that meets only flat walls
/// aligned with it (no point is too close, and the lattice is at rest density).
struct FillConfig
{
  // Leave out lattice points closer than one spacing to a boundary particle of a solid or a
  // container (Eq. A21): nearer, the wall's layer alone compresses the point above rest density.
  bool trim = true;  //                                                key: fill.trim
  // Relax the lattice (Eq. A22) when it departs from rest density by more than relax_tolerance
  // (Eq. A23): pseudo-steps of the density solve from rest under gravity, velocities set back to
  // zero after each, walls held still, until it is within the tolerance and held.
  bool relax = true;  //                                               key: fill.relax
  // Relative density error, in (0, 1). Above what a lattice aligned with flat walls starts with
  // (float rounding, 3e-5, and 1.24 % next to the convex corners of a solid box, hydrostatic_tank's
  // cube) and the compression settled water keeps under its own weight (0.3 % at 0.5 m depth),
  // far below a curved wall's cut (15-30 %).
  double relax_tolerance = 0.02;  //                                   key: fill.relax_tolerance
  int relax_max_steps = 150;      // pseudo-steps, at most            key: fill.relax_max_steps
};

struct TimeStepConfig
{
  bool adaptive = false;  // {cfl: ...} given
  double fixed = 0.001;   // s                 key: time_step.fixed
  double cfl = 0.4;       // dimensionless     key: time_step.cfl (dt = cfl * spacing / max speed)
  double min = 1.0e-5;    // s                 key: time_step.min
  double max = 0.005;     // s                 key: time_step.max
};

enum class ViscosityModel
{
  None,
  Artificial,  // Monaghan-style artificial viscosity (coefficient = kinematic viscosity nu, m^2/s)
  Xsph         // XSPH velocity smoothing (coefficient dimensionless, 0..1)
};
const char* toString(ViscosityModel model);

/// A number as error messages print it (the stream's default: up to 6 significant digits).
std::string numberText(double v);
/// A vector as error messages print it: "(x, y, z)", each as numberText prints it.
std::string vectorText(const Vec3d& v);

struct ViscosityConfig
{
  ViscosityModel model = ViscosityModel::None;  // key: viscosity.model: none | artificial | xsph
  double coefficient = 0.0;                     // key: viscosity.coefficient (m^2/s for artificial, unit-less for xsph)
  double boundary = 0.0;  // key: viscosity.boundary: same units against walls; > 0 = no-slip-like walls
};

struct SolverConfig
{
  BoundaryPressureMethod boundary_pressure = BoundaryPressureMethod::Mls;  // key: solver.boundary_pressure
  double density_error = 0.001;            // relative, mean over particles   key: solver.density_error
  double divergence_error = 0.001;         // relative per step                key: solver.divergence_error
  int min_iterations = 2;                  // density solve                    key: solver.min_iterations
  int max_iterations = 100;                // both solves                      key: solver.max_iterations
  int min_divergence_iterations = 1;       //                                key: solver.min_divergence_iterations
  bool divergence_solve = true;            // key: solver.divergence_solve (paper Sec. 5.1 runs without it)
  bool warm_start = false;                 // key: solver.warm_start
  ColdStart cold_start = ColdStart::Zero;  // without warm_start  key: solver.cold_start: zero | jacobi
  WarmStartGuess warm_start_guess = WarmStartGuess::Previous;  // key: solver.warm_start_guess
  double omega = 0.5;                                          // relaxed Jacobi factor            key: solver.omega
  // The density solve's sweeps: jacobi (Eq. A8) | gauss_seidel (Eq. A8b: about half the sweeps
  // from a cold start in deep water, each 1.3 times as costly; next to a wall the step is
  // relaxed by omega as in A8).  key: solver.sweep
  SweepOrder sweep = SweepOrder::Jacobi;
  // With warm_start, the divergence solve too starts from the previous step's guess; off, it
  // starts as without warm_start (cold_start), which in the measured scenes converged in as many
  // iterations (1.00-1.02 per step) with fewer passes over the pairs.  key: solver.warm_start_divergence
  bool warm_start_divergence = false;
  // Chebyshev semi-iteration over the relaxed Jacobi sweeps (Eq. A8a): rho, the assumed spectral
  // radius of one sweep (A8), in (0, 1); 0 = off, plain sweeps (the paper's). After `delay` plain
  // sweeps each update is extrapolated from the one before the last; it pays where many sweeps
  // are needed in shallow water (cold starts, fine spacings: robot tanks); in 1 m deep columns it
  // blew up with sph and mls (docs/performance.md).
  double chebyshev_rho = 0.0;           //                                  key: solver.chebyshev_rho
  int chebyshev_delay = 3;              // plain sweeps first, >= 1        key: solver.chebyshev_delay
  bool clamp_boundary_pressure = true;  // p_b >= 0 in the density solve key: solver.clamp_boundary_pressure
  // Limit each extrapolated p_b (sph, mls) to the range of its fluid neighbours' pressures,
  // widened by rho0 |g - a_b| times the fit radius (Eq. A11: the largest hydrostatic difference
  // between b and a neighbour of its fit, so it never binds in water at rest). It stops a fit
  // over few one-sided neighbours (a splash, an impact) from extrapolating a wall pressure the
  // water around it could not hold: without it MLS shoots single particles off in the 1 cm
  // cylinder dam break from 1.4-1.75 ms (docs/method_notes.md). false = the paper's fit.
  bool limit_boundary_pressure = true;  //                              key: solver.limit_boundary_pressure
  // The wall guard (Eq. A31, wall_guard.h): no step ends a fluid particle closer to the boundary
  // particles' layer than this many spacings from a flat layer (or than it already was). 0 = off,
  // the default for now: on, it changes the dam breaks of the validation suite (mirroring's front
  // 5 % faster in the quick case), which the full suite has not been rerun for. The layer lies
  // half a spacing inside a solid, so 0.5 keeps the water out of the solid's surface; water at
  // rest sits a whole spacing from the layer.  key: solver.wall_guard
  double wall_guard = 0.0;
  // Include in the Jacobi diagonal A_i (Eq. A4) the dependence of the extrapolated p_b (sph,
  // mls) on p_i through its coefficient c_bi (Eq. A4b). Mirroring's p_b = p_i always has it.
  bool diagonal_feedback = false;  //                              key: solver.diagonal_feedback
  // Diagnostic: false leaves the boundary velocities v_b out of the density rate (Eq. A2), as if
  // every wall stood still there (its positions and forces still move). Only meaningful for a
  // wall sliding along itself, to split a turning container's drag on the water.
  bool wall_velocity_in_density_rate = true;  //       key: solver.wall_velocity_in_density_rate
  double mls_fit_radius = 2.0;                // spacings; radius of the MLS fit  key: solver.mls_fit_radius
  // tau of Eq. A20 (regularized: the damping scale) or the smallest/largest eigenvalue ratio
  // below which M_b counts as singular (fallback, pseudo_inverse).
  double mls_eigen_tolerance = 0.1;                             // key: solver.mls_eigen_tolerance
  MlsSingularMode mls_singular = MlsSingularMode::Regularized;  // key: solver.mls_singular
};

/// When a run is declared unstable (reported, never thrown).
struct StabilityConfig
{
  double max_density_error = 0.1;  // mean relative density error   key: stability.max_density_error
  double max_cfl = 2.0;            // max speed * dt / spacing        key: stability.max_cfl
};

struct OutputConfig
{
  double frame_interval = 0.01;  // s between PLY frames; 0 = none   key: output.frame_interval
};

/// Instruments (README, Instruments). They read the fluid after a step and never act on
/// it: a scene without them runs exactly as before.
enum class RegionShape
{
  Box,     // key: box {min, max} (with an optional pose)
  Sphere,  // key: sphere {center, radius}
  Body     // key: body NAME: the inside of a boundary body or URDF link, following its pose
};

/// A named volume the water in it is measured in (key regions[i]).
struct RegionConfig
{
  // key: name. A ROS base name (a letter, then letters, digits or '_'): the node publishes the
  // region on regions/<name> and the runner writes it as is into regions.csv.
  std::string name;
  RegionShape shape = RegionShape::Box;
  AxisBox box;         // m, in the region's frame                  key: box {min, max}
  Pose pose;           // region frame -> world (a box only)        key: pose {xyz, rpy}
  SphereShape sphere;  // m, world                                  key: sphere {center, radius}
  // key: body. A boundary body's name (a URDF link's is the link name). Its inside: a primitive's
  // solid, a closed mesh's enclosed volume, an open mesh (a cup) closed over each opening of its
  // border (the rim), so the volume it holds up to its rim. Checked against the bodies when the
  // instruments are built (the node adds the URDF links after the scene is read).
  std::string body;
};

/// A point the fluid's pressure, velocity and density are interpolated at (key probes[i]).
struct ProbeConfig
{
  std::string name;                // key: name, a ROS base name like a region's
  Vec3d position = Vec3d::Zero();  // m, world                       key: position
};

/// Water outside every region and below a height: spilt (key spill).
struct SpillConfig
{
  bool enabled = false;  // the scene has a spill key
  double below = 0.0;    // m, world z                             key: spill.below
};

/// A nozzle that adds water during the run (key emitters[i]; emitters.h, docs/method.md Emitters).
enum class NozzleShape
{
  Circle,    // key: circle {radius}
  Rectangle  // key: rectangle {size: [w, h]}, along the nozzle frame's x and y
};

struct EmitterConfig
{
  std::string name;  // key: name, a ROS base name like a region's
  NozzleShape shape = NozzleShape::Circle;
  double radius = 0.0;                             // m, circle               key: circle.radius
  Eigen::Vector2d size = Eigen::Vector2d::Zero();  // m, rectangle            key: rectangle.size
  // Nozzle frame -> world, or -> the body's frame when attached: the opening is centred on the
  // frame's origin in its x-y plane and the water leaves along its +z axis.
  // key: pose {xyz, rpy}, or pose {xyz} with direction [x, y, z] (the +z axis)
  Pose pose;
  double speed = 0.0;      // m/s, exit speed         key: speed
  double flow_rate = 0.0;  // m^3/s                   key: flow_rate (exactly one of speed, flow_rate)
  double start = 0.0;      // s, emits from then on   key: start
  double duration = std::numeric_limits<double>::infinity();  // s      key: duration (default: no end)
  // key: body. A boundary body's name (a URDF link's is the link name): the nozzle is fixed in
  // its frame and moves with it; the water leaves with the body's velocity at the nozzle added.
  std::string body;
  // key: max_particles. The most particles it emits (0: as many as flow_rate x duration makes,
  // or, without a duration, until the scene's max_fluid_particles is reached).
  std::size_t max_particles = 0;
  // key: frame (the ROS node only). A tf frame the nozzle is fixed in (pose relative to it): the
  // node looks it up before every step and poses the nozzle (Simulation::setEmitterPose).
  std::string frame;
  bool externally_posed = false;  // posed by the caller (set with frame)
};

/// How contacts between bodies are found and resolved (docs/method.md, Free bodies, Eq. A26).
enum class ContactModel
{
  Bullet,    // Bullet's collision detection and contact solver on the bodies' shapes (bullet_contacts.h)
  Particles  // impulses on pairs of boundary particles (ContactSolver, rigid_dynamics.h)
};

/// Contacts between bodies, where a free body is involved (docs/method.md, Free bodies).
struct ContactConfig
{
  double friction = 0.5;                      // Coulomb coefficient, unit-less, >= 0   key: contacts.friction
  ContactModel model = ContactModel::Bullet;  // key: contacts.model (bullet | particles)
  // Rolling resistance (model bullet): a free body's rolling is resisted by a torque up to
  // rolling_resistance x r x N, r its inner radius (m), N the normal force (N). Unit-less, >= 0.
  // Bullet's contacts set a round body lying on a face rolling by themselves (docs/method_notes.md,
  // Free bodies); 0.01 stops that for radii of 1-20 cm.   key: contacts.rolling_resistance
  double rolling_resistance = 0.01;
};
const char* toString(ContactModel model);

struct SceneConfig
{
  std::string source = "<scene>";                     // file name, for messages
  double spacing = 0.02;                              // m; kernel support is 2 x spacing   key: spacing
  double rest_density = 1000.0;                       // kg/m^3                            key: rest_density
  Vec3d gravity{0.0, 0.0, -9.81};                     // m/s^2                             key: gravity
  AxisBox domain{Vec3d(-1, -1, -1), Vec3d(2, 2, 2)};  // m              key: domain
  TimeStepConfig time_step;
  SolverConfig solver;
  ViscosityConfig viscosity;
  StabilityConfig stability;
  std::vector<FluidBlockConfig> fluid;     // key: fluid
  FillConfig fill;                         // key: fill
  std::vector<BoundaryConfig> boundaries;  // key: boundaries
  OutputConfig output;
  std::vector<RegionConfig> regions;  // key: regions
  std::vector<ProbeConfig> probes;    // key: probes
  SpillConfig spill;                  // key: spill
  ContactConfig contacts;             // key: contacts
  // Drains (key sinks: a box with an optional pose, or a sphere; a name as a region's): water
  // that enters one after a step is removed and counted against it. Never a body region.
  std::vector<RegionConfig> sinks;
  std::vector<EmitterConfig> emitters;  // key: emitters
  double duration = 1.0;                // s, default run length for the runner     key: duration
  /// Largest number of boundary particles one body may be sampled into; validate() refuses a
  /// body whose estimate (from its surface area and sample spacing) exceeds it, before sampling.
  std::size_t max_boundary_particles = 2000000;  //                    key: max_boundary_particles
  /// Largest number of fluid particles the scene may start with (lattice points of every box
  /// block before trimming, plus explicit particles); validate() refuses more, before any is made.
  std::size_t max_fluid_particles = 20000000;  //                      key: max_fluid_particles
  /// Notes from loading the scene that are not errors (a URDF link without collision geometry
  /// skipped, an open mesh used as a solid, degenerate triangles skipped), each naming its file.
  /// Set by io; the caller shows them (the runner prints them to stderr).
  std::vector<std::string> warnings;
};

/// Checks ranges and consistency; throws ConfigError whose key is the dotted scene key
/// (e.g. "solver.density_error", "boundaries[1].sphere.radius").
void validate(const SceneConfig& scene);

}  // namespace fluid_sim
