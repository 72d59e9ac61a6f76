#pragma once
// Contacts between bodies by Bullet (`contacts.model: bullet`, the default; docs/method.md, Free
// bodies, Eqs. A26b, A27): Bullet's collision detection on each body's geometry and its contact
// solver (sequential impulses with Coulomb friction) change the free bodies' velocities after
// gravity and the fluid's wrench (Eqs. A24, A25); our integrator then moves them (Eq. A24's
// positions). Built only for a scene with free bodies; Bullet stays out of this header.

#include <cstddef>
#include <memory>

#include "fluid_sim/core/rigid_dynamics.h"
#include "fluid_sim/core/scene_config.h"

namespace fluid_sim
{
class BodySet;

class BulletContacts : public ContactResolver
{
public:
  /// One Bullet object per body, from its BoundaryConfig: a box, sphere or cylinder as Bullet's
  /// primitive; a box container (`inside: true`) as six walls outside its inner faces; a sphere or
  /// cylinder container, and every static or moving mesh, as a triangle mesh; a free mesh as its
  /// convex hull (shrunk by the collision margin). Free bodies are dynamic (their mass, centre of
  /// mass and inertia in principal axes), the others static, or kinematic if they move. `spacing`
  /// (m) bounds the collision margin (a tenth of it, at most 1 mm). Throws ConfigError, naming
  /// the body, for a free container that is not a box.
  BulletContacts(const BodySet& bodies, double spacing, const ContactConfig& config);
  ~BulletContacts() override;

  /// Eq. A26b: hands Bullet every body's pose at the step's start and velocity (the free bodies'
  /// after Eqs. A24, A25), lets it find the contacts and solve them over `dt` (s), and adds the
  /// velocity changes it made to the free bodies' v_com and omega; Eq. A27: contact_force.
  void apply(BodySet& bodies, double dt) override;

  /// Contact points of the last apply().
  std::size_t contacts() const;
  /// m, the collision margin of the shapes (boxes, spheres and cylinders keep it inside their
  /// surface; triangle meshes add it outside theirs).
  double margin() const;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace fluid_sim
