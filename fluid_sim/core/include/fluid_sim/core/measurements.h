#pragma once
// Instruments (scene keys regions, probes, spill): what the water does in named volumes and at
// named points, read from the fluid state between steps. They never act on the simulation, and
// a scene that declares none builds nothing and evaluates nothing.

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "fluid_sim/core/scene_config.h"
#include "fluid_sim/core/types.h"

namespace fluid_sim
{
class Simulation;
class UniformGrid;

/// A region's (or a sink's) inside test, with the rotation as a matrix: built once per
/// evaluation or step, not per particle.
struct RegionTest
{
  RegionShape shape;
  Mat3d world_to_local;                  // R^T of the box's or the body's pose
  Vec3d translation;                     // m, of that pose
  Vec3d min, max;                        // m, the box in its frame
  Vec3d center;                          // m, the sphere's
  double radius2;                        // m^2, the sphere's squared radius
  const BoundaryConfig* body = nullptr;  // the body's shape in its frame (a body region)

  /// `pose`: the box's (a region's or a sink's own) or the body's; `body_shape` for a body region.
  RegionTest(const RegionConfig& r, const Pose& pose, const BoundaryConfig* body_shape);
  bool contains(const Vec3d& p) const;  // p in m, world
};

/// The water inside one region.
struct RegionMeasurement
{
  std::string name;
  std::size_t particles = 0;            // fluid particles inside
  double volume = 0.0;                  // m^3, particles * m / rho0
  double mass = 0.0;                    // kg, particles * m
  double capacity = 0.0;                // m^3, the region's geometric volume
  double fill_fraction = 0.0;           // volume / capacity
  Vec3d mean_velocity = Vec3d::Zero();  // m/s, mean over the particles inside (0 when empty)
};

/// The fluid interpolated at one probe (SPH, cubic kernel of the simulation's support).
struct ProbeMeasurement
{
  std::string name;
  Vec3d position = Vec3d::Zero();  // m, world
  // Enough fluid around the probe to call it under water: 2 phi_f + phi_b >= 1 (see wetness()).
  // A dry probe reads pressure 0 and velocity 0; its density is still the SPH sum.
  bool wet = false;
  double pressure = 0.0;           // Pa, Shepard-normalised over the fluid neighbours
  double density = 0.0;            // kg/m^3, sum_f m W + sum_b rho0 V_b W (the solver's Eq. A1)
  Vec3d velocity = Vec3d::Zero();  // m/s, Shepard-normalised over the fluid neighbours
  double fluid_support = 0.0;      // phi_f = sum_f (m / rho0) W, 1 deep inside water
  double wall_support = 0.0;       // phi_b = sum_b V_b W, about 0.5 on a wall's surface
};

/// Fluid outside every region and below the scene's spill.below.
struct SpillMeasurement
{
  bool enabled = false;       // the scene has a spill key (otherwise nothing is counted)
  double below = 0.0;         // m, world z
  std::size_t particles = 0;  // fluid particles outside every region with z < below
  double volume = 0.0;        // m^3, particles * m / rho0
  double mass = 0.0;          // kg
};

struct MeasurementReport
{
  double time = 0.0;                       // s, the simulated time of the state measured
  std::vector<RegionMeasurement> regions;  // in the scene's order
  std::vector<ProbeMeasurement> probes;    // in the scene's order
  SpillMeasurement spill;
};

/// `mesh` with each opening of its border (the chains of edges only one triangle has, grouped by
/// shared vertices) closed by a fan from the opening's centroid, oriented so that the result
/// encloses a positive volume: a cup's inside up to its rim. A closed mesh comes back as it is
/// (oriented outward).
TriangleMesh closeOpenings(const TriangleMesh& mesh);

/// Volume enclosed by a closed mesh, m^3 (divergence theorem); negative if its normals point inward.
double enclosedVolume(const TriangleMesh& mesh);

/// The wetness rule of a probe from its fluid support phi_f = sum_f (m/rho0) W and wall support
/// phi_b = sum_b V_b W: wet when 2 phi_f + phi_b >= 1, i.e. when fluid fills at least as much of
/// the kernel as the empty part 1 - phi_f - phi_b does. Deep in water phi_f = 1; on a flat free
/// surface phi_f = 0.5 (the threshold: the surface is where half the kernel is water); on a
/// submerged wall phi_f = phi_b = 0.5 (wet); on a dry floor phi_f = 0 (dry). A fixed threshold on
/// phi_f alone would call a probe on a submerged wall (phi_f about 0.5) dry as often as wet.
bool wetness(double fluid_support, double wall_support);

class Measurements
{
public:
  /// Takes the instruments of the scene `sim` was built from. A region's `body` must name one of
  /// its bodies (else ConfigError naming regions[i].body); an open mesh's openings are closed
  /// here, once.
  explicit Measurements(const Simulation& sim);
  ~Measurements();
  Measurements(const Measurements&) = delete;
  Measurements& operator=(const Measurements&) = delete;

  /// The scene declares no region, probe or spill: evaluate() returns an empty report at once.
  bool empty() const;
  const std::vector<RegionConfig>& regions() const
  {
    return regions_;
  }
  const std::vector<ProbeConfig>& probes() const
  {
    return probes_;
  }
  bool spillEnabled() const
  {
    return spill_.enabled;
  }

  /// Measures the state of `sim` (built from the same scene) as it is now, after a step.
  /// Cost: one pass over the fluid particles for the regions and the spill (each particle tested
  /// against every region), and for the probes a counting sort of the fluid and boundary
  /// particles into a grid around them.
  /// `probes` false leaves the probes out (a caller that reads them after every step already has
  /// this step's).
  MeasurementReport evaluate(const Simulation& sim, bool probes = true);
  /// The probes alone (report.probes as evaluate() gives them; time set, regions and spill left
  /// empty): what a mean of the probes over many steps needs each step.
  MeasurementReport evaluateProbes(const Simulation& sim);

  /// The geometric volume of region k, m^3.
  double capacity(std::size_t k) const
  {
    return capacity_[k];
  }

private:
  void measureRegions(const Simulation& sim, MeasurementReport& out) const;
  void measureProbes(const Simulation& sim, MeasurementReport& out);

  std::vector<RegionConfig> regions_;
  std::vector<double> capacity_;  // m^3, per region
  // Per region: the body (index) and its shape as tested, in the body frame (an open mesh
  // closed over its openings); unused for box and sphere regions.
  std::vector<std::size_t> body_index_;
  std::vector<BoundaryConfig> body_shape_;
  std::vector<ProbeConfig> probes_;
  SpillConfig spill_;
  AxisBox domain_;  // m, the scene's: fluid never is outside it
  double support_;  // m, kernel support h = 2 spacing
  double mass_;     // kg per fluid particle
  double rho0_;     // kg/m^3
  // Grids around the probes (built on the first evaluation with probes), for the fluid and the
  // boundary particles.
  std::unique_ptr<UniformGrid> fluid_grid_, boundary_grid_;
};

}  // namespace fluid_sim
