#pragma once
// Free rigid bodies (scene key `dynamic`, docs/method.md, Free bodies): mass properties of the
// boundary shapes, the Newton-Euler step under gravity and the fluid's wrench (Eqs. A24, A25), and
// contacts between bodies resolved as impulses on pairs of boundary particles (Eq. A26; the
// default model, Bullet's, is in bullet_contacts.h).

#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "fluid_sim/core/scene_config.h"
#include "fluid_sim/core/types.h"

namespace fluid_sim
{
class BodySet;

/// Volume, centroid and inertia of a solid of unit density.
struct ShapeMass
{
  double volume = 0.0;             // m^3
  Vec3d centroid = Vec3d::Zero();  // m, body frame
  Mat3d inertia = Mat3d::Zero();   // m^5 (kg m^2 per kg/m^3), about the centroid, body axes
};

/// The closed shape's volume, centroid and unit-density inertia (box, sphere, cylinder: exact; a
/// closed mesh: exact for the polyhedron, by signed tetrahedra from the origin). Throws
/// ConfigError for an open mesh or a mesh whose enclosed volume is not positive (inward normals).
ShapeMass shapeMass(const BoundaryConfig& b, const std::string& key);

/// A free body's mass (kg), centre of mass (m, body frame) and inertia about it (kg m^2, body
/// axes), from its `dynamic` entry: given values where present, otherwise from the shape and the
/// density (or the mass spread uniformly). A given centre of mass without a given inertia moves
/// the shape's inertia there (parallel axes).
struct MassProperties
{
  double mass = 0.0;
  Vec3d com = Vec3d::Zero();
  Mat3d inertia = Mat3d::Zero();
};
MassProperties massProperties(const BoundaryConfig& b, const std::string& key);

/// The inertia matrix from URDF-ordered values ixx, iyy, izz, ixy, ixz, iyz (kg m^2).
Mat3d inertiaMatrix(const std::array<double, 6>& values);

/// Contacts between bodies where at least one is free: given the free bodies' velocities after
/// gravity and the fluid's wrench (Eqs. A24, A25) and every body's pose at the step's start, changes
/// the free bodies' velocities (v_com, omega) by the contacts' impulses over the step `dt` (s) and
/// sets each body's contact_force (N, world) to the impulses it received over dt. Two models:
/// ContactSolver below (`contacts.model: particles`, Eq. A26) and BulletContacts
/// (bullet_contacts.h, `contacts.model: bullet`, Eqs. A26b, A27).
class ContactResolver
{
public:
  virtual ~ContactResolver() = default;
  virtual void apply(BodySet& bodies, double dt) = 0;
};

/// Contacts between bodies where at least one is free (Eq. A26): pairs of boundary particles of
/// different bodies closer than the contact distance plus a margin, resolved by sequential
/// impulses with Coulomb friction. Kinematic bodies (static, scripted, posed from outside) push
/// free ones and are not pushed back.
class ContactSolver : public ContactResolver
{
public:
  /// `spacing`: the scene's fluid spacing (m). Two solids in touch have their boundary layers one
  /// spacing apart (each is inset by half a spacing), which is the contact distance.
  ContactSolver(double spacing, const ContactConfig& config);

  /// Finds the contacts at the particles' current positions and changes the free bodies'
  /// velocities (v_com, omega) so that no contact closes faster than its gap allows over `dt`
  /// (s) and none pushes apart faster than a fraction of its overlap per step. Each body's
  /// contact_force (N, world) is set to the impulses it received over dt.
  void apply(BodySet& bodies, double dt) override;

  std::size_t contacts() const
  {
    return contacts_.size();
  }

private:
  struct Contact
  {
    std::uint32_t a;  // free body
    std::int32_t b;   // free body, or -1 (kinematic particle)
    std::uint32_t particle_b;
    Vec3d n;                         // unit, from b to a
    Vec3d ra, rb;                    // m, from each centre of mass to the contact point
    double gap;                      // m, distance minus contact distance (negative: overlap)
    double mass_n;                   // kg, effective mass along n
    double lambda_n = 0.0;           // N s, accumulated normal impulse
    Vec3d lambda_t = Vec3d::Zero();  // N s, accumulated friction impulse
  };
  void find(const BodySet& bodies, double dt);

  double distance_;  // m, contact distance
  ContactConfig config_;
  std::vector<Contact> contacts_;
  std::unordered_map<std::int64_t, std::vector<std::uint32_t>> grid_;  // scratch: cell -> kinematic/free particles
};

}  // namespace fluid_sim
