// fluid_sim_contact_bench: contacts between rigid bodies without fluid, the project's particle
// contacts against Bullet's. The same dry scenarios (gravity only) run once on the core's free
// bodies exactly as Simulation steps them (BodySet::stepFree with a ContactSolver, Eqs. A24-A26 of
// docs/method.md) and once in a Bullet world (btDiscreteDynamicsWorld, the same shapes as Bullet
// primitives); one table row per scenario, spacing and engine. Measures; it is not a test. The
// particle engine is `contacts.model: particles`; the integrated default (BulletContacts,
// bullet_contacts.h) is tested in test/core/bullet_contact_test.cpp. The figures and the decision
// they fed are in docs/method_notes.md, "Contacts: boundary particles against Bullet".
//
//   fluid_sim_contact_bench [--spacing S ...] [--scenario NAME ...] [--threads N]
//                           [--friction MU] [--angle DEG ...] [--yaw DEG ...] [--speed V ...]
//                           [--margin M] [--iterations N] [--mesh FILE]

#include <btBulletDynamicsCommon.h>
#include <tbb/global_control.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "fluid_sim/core/bodies.h"
#include "fluid_sim/core/rigid_dynamics.h"
#include "fluid_sim/core/scene_config.h"
#include "fluid_sim/core/types.h"
#include "fluid_sim/io/mesh_loader.h"

namespace
{
using namespace fluid_sim;
using Clock = std::chrono::steady_clock;

constexpr double kDt = 0.001;  // s, the fluid's fixed time step
constexpr double kG = 9.81;    // m/s^2
double kMu = 0.5;              // Coulomb friction coefficient (contacts.friction; --friction)

// ------------------------------------------------------------------------------ scenario bodies

enum class Kind
{
  Free,       // a `dynamic` body
  Static,     // a solid that never moves
  Container,  // a box tank (`inside: true`), its inner box centred on the pose
  Scripted    // a kinematic box moving at a constant velocity (`motion.linear_velocity`)
};

/// One body of a scenario, engine-neutral. Boxes and spheres are centred on the body origin; a
/// mesh is in its body frame.
struct Spec
{
  std::string name;
  Kind kind = Kind::Free;
  ShapeType shape = ShapeType::Box;
  Vec3d size = Vec3d::Zero();      // m, box edge lengths (a container's inner size)
  double radius = 0.0;             // m, sphere
  TriangleMesh mesh;               // m, closed, body frame
  Pose pose;                       // body -> world at t = 0
  double density = 1000.0;         // kg/m^3, free bodies
  Vec3d velocity = Vec3d::Zero();  // m/s: a free body's initial one, a scripted body's constant one
};

Spec box(const std::string& name, Kind kind, const Vec3d& size, const Vec3d& centre,
         const Eigen::Quaterniond& rotation = Eigen::Quaterniond::Identity(), double density = 1000.0)
{
  Spec b;
  b.name = name;
  b.kind = kind;
  b.size = size;
  b.pose.translation = centre;
  b.pose.rotation = rotation;
  b.density = density;
  return b;
}

Spec sphere(const std::string& name, double radius, const Vec3d& centre, double density)
{
  Spec b;
  b.name = name;
  b.shape = ShapeType::Sphere;
  b.radius = radius;
  b.pose.translation = centre;
  b.density = density;
  return b;
}

/// A box tank with its floor at z = 0 and its inner corner at the origin.
Spec tank(const Vec3d& size)
{
  return box("tank", Kind::Container, size, 0.5 * size);
}

/// The scene entry a YAML file would make of `b`.
BoundaryConfig boundaryOf(const Spec& b)
{
  BoundaryConfig c;
  c.name = b.name;
  c.type = b.shape;
  c.pose = b.pose;
  if (b.shape == ShapeType::Box) c.box = {-0.5 * b.size, 0.5 * b.size};
  if (b.shape == ShapeType::Sphere) c.sphere = {Vec3d::Zero(), b.radius};
  if (b.shape == ShapeType::Mesh)
  {
    c.mesh = b.mesh;
    c.mesh_closed = true;
  }
  c.inside = b.kind == Kind::Container;
  if (b.kind == Kind::Scripted) c.motion.linear_velocity = b.velocity;
  if (b.kind == Kind::Free)
  {
    c.dynamic.enabled = true;
    c.dynamic.density = b.density;
    c.dynamic.linear_velocity = b.velocity;
  }
  return c;
}

// ------------------------------------------------------------------------------------ engines

/// A body's motion as both engines report it.
struct State
{
  Vec3d com = Vec3d::Zero();  // m, world: the centre of mass (free), the body origin (others)
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();  // body -> world
  Vec3d v = Vec3d::Zero();                                       // m/s, of com
  Vec3d omega = Vec3d::Zero();                                   // rad/s, world
};

class Engine
{
public:
  virtual ~Engine() = default;
  /// One step of kDt.
  virtual void step() = 0;
  /// Body `i` in the order of the scenario's specs.
  virtual State state(std::size_t i) const = 0;
  /// Boundary particles (0 for Bullet).
  virtual std::size_t particles() const
  {
    return 0;
  }
  double time() const
  {
    return t_;
  }

protected:
  double t_ = 0.0;  // s
};

/// The core's free bodies and contacts, stepped as Simulation::Impl::advance() steps them.
class ParticleEngine : public Engine
{
public:
  ParticleEngine(const std::vector<Spec>& specs, double spacing)
      : scene_(sceneOf(specs, spacing)), bodies_(scene_), contacts_(scene_.spacing, scene_.contacts)
  {
  }

  void step() override
  {
    // Step 0 of advance(): kinematic bodies to their poses at t (Eq. A17). Without fluid the
    // bodies' force and torque stay zero, so stepFree() applies gravity (Eqs. A24, A25) and the
    // contacts (Eq. A26) and moves the free bodies to t + dt.
    bodies_.poseMoving(t_);
    bodies_.stepFree(kDt, scene_.gravity, contacts_);
    t_ += kDt;
  }

  State state(std::size_t i) const override
  {
    const Body& b = bodies_[i];
    State s;
    s.rotation = b.pose.rotation;
    s.com = b.free ? b.centerOfMass() : b.pose.translation;
    s.v = b.free ? b.v_com : b.v_origin;
    s.omega = b.omega;
    return s;
  }

  std::size_t particles() const override
  {
    return bodies_.numParticles();
  }

private:
  static SceneConfig sceneOf(const std::vector<Spec>& specs, double spacing)
  {
    SceneConfig s;
    s.spacing = spacing;
    s.time_step.fixed = kDt;
    s.gravity = Vec3d(0.0, 0.0, -kG);
    s.contacts.friction = kMu;
    s.contacts.model = ContactModel::Particles;  // this engine is the particle contacts (ContactSolver)
    s.domain = {Vec3d(-2, -2, -2), Vec3d(2, 2, 2)};
    // validate() wants a fluid block: a drop far from every body, never stepped here.
    FluidBlockConfig drop;
    drop.box = {Vec3d(1.8, 1.8, 1.8), Vec3d(1.8, 1.8, 1.8) + Vec3d::Constant(2.0 * spacing)};
    s.fluid.push_back(drop);
    for (const Spec& b : specs) s.boundaries.push_back(boundaryOf(b));
    validate(s);
    return s;
  }

  SceneConfig scene_;
  BodySet bodies_;
  ContactSolver contacts_;
};

struct BulletSettings
{
  double margin = 0.001;  // m, collision margin of every shape (Bullet's default: 0.04)
  int iterations = 10;    // solver iterations (Bullet's default)
  bool ccd = false;       // continuous collision detection for the free bodies
};

btVector3 toBt(const Vec3d& v)
{
  return btVector3(btScalar(v.x()), btScalar(v.y()), btScalar(v.z()));
}
Vec3d fromBt(const btVector3& v)
{
  return Vec3d(v.x(), v.y(), v.z());
}
btTransform toBt(const Pose& p)
{
  btTransform t;
  t.setOrigin(toBt(p.translation));
  t.setRotation(btQuaternion(btScalar(p.rotation.x()), btScalar(p.rotation.y()), btScalar(p.rotation.z()),
                             btScalar(p.rotation.w())));
  return t;
}

/// The same bodies in a Bullet world: free bodies as dynamic rigid bodies with the core's mass
/// properties, solids as static boxes, a container as five static boxes (floor and walls), a
/// scripted box as a kinematic body posed every step. Friction: Bullet multiplies the two bodies'
/// coefficients, so each gets sqrt(mu). Restitution 0, no sleeping (a body in water never sleeps).
class BulletEngine : public Engine
{
public:
  BulletEngine(const std::vector<Spec>& specs, const BulletSettings& settings)
      : dispatcher_(&config_), world_(&dispatcher_, &broadphase_, &solver_, &config_), specs_(specs)
  {
    world_.setGravity(btVector3(0, 0, btScalar(-kG)));
    world_.getSolverInfo().m_numIterations = settings.iterations;
    // CCD stops a sweep only when it would overlap by more than this (Bullet's default: 4 cm,
    // the size of the bodies here): the margin instead.
    if (settings.ccd) world_.getDispatchInfo().m_allowedCcdPenetration = btScalar(settings.margin);
    for (std::size_t i = 0; i < specs.size(); ++i) add(specs[i], settings);
  }
  ~BulletEngine() override
  {
    for (auto& b : owned_) world_.removeRigidBody(b.get());  // before the bodies go
  }

  void step() override
  {
    // A kinematic body's velocity is Bullet's difference of its motion state's poses over the
    // step: pose it at the step's end.
    for (std::size_t i = 0; i < specs_.size(); ++i)
      if (specs_[i].kind == Kind::Scripted)
      {
        Pose p = specs_[i].pose;
        p.translation += specs_[i].velocity * (t_ + kDt);
        entries_[i].motion->setWorldTransform(toBt(p));
      }
    world_.stepSimulation(btScalar(kDt), 0);  // 0: one step of exactly kDt
    t_ += kDt;
  }

  State state(std::size_t i) const override
  {
    State s;
    const Entry& e = entries_[i];
    if (!e.body)  // a container
    {
      s.com = specs_[i].pose.translation;
      return s;
    }
    const btTransform& t = e.body->getCenterOfMassTransform();
    const btQuaternion q = t.getRotation();
    s.rotation = Eigen::Quaterniond(q.w(), q.x(), q.y(), q.z());
    s.com = fromBt(t.getOrigin());
    s.v = fromBt(e.body->getLinearVelocity());
    s.omega = fromBt(e.body->getAngularVelocity());
    return s;
  }

private:
  struct Entry
  {
    btRigidBody* body = nullptr;  // none for a container
    btDefaultMotionState* motion = nullptr;
  };

  btRigidBody* addBody(btCollisionShape* shape, const btTransform& pose, double mass, const btVector3& inertia,
                       const BulletSettings& settings, btDefaultMotionState** motion_out = nullptr)
  {
    shape->setMargin(btScalar(settings.margin));
    auto motion = std::make_unique<btDefaultMotionState>(pose);
    btRigidBody::btRigidBodyConstructionInfo info(btScalar(mass), motion.get(), shape, inertia);
    info.m_friction = btScalar(std::sqrt(kMu));
    info.m_restitution = 0;
    auto body = std::make_unique<btRigidBody>(info);
    body->setActivationState(DISABLE_DEACTIVATION);
    world_.addRigidBody(body.get());
    if (motion_out) *motion_out = motion.get();
    motions_.push_back(std::move(motion));
    owned_.push_back(std::move(body));
    return owned_.back().get();
  }

  btCollisionShape* keep(std::unique_ptr<btCollisionShape> shape)
  {
    shapes_.push_back(std::move(shape));
    return shapes_.back().get();
  }

  void add(const Spec& b, const BulletSettings& settings)
  {
    Entry e;
    if (b.kind == Kind::Container)
    {
      // Floor and four walls, kThick thick, outside the inner box.
      constexpr double kThick = 0.1;  // m
      const Vec3d h = 0.5 * b.size, c = b.pose.translation;
      const Vec3d halves[5] = {{h.x() + kThick, h.y() + kThick, 0.5 * kThick},
                               {0.5 * kThick, h.y() + kThick, h.z()},
                               {0.5 * kThick, h.y() + kThick, h.z()},
                               {h.x(), 0.5 * kThick, h.z()},
                               {h.x(), 0.5 * kThick, h.z()}};
      const Vec3d centres[5] = {c - Vec3d(0, 0, h.z() + 0.5 * kThick), c - Vec3d(h.x() + 0.5 * kThick, 0, 0),
                                c + Vec3d(h.x() + 0.5 * kThick, 0, 0), c - Vec3d(0, h.y() + 0.5 * kThick, 0),
                                c + Vec3d(0, h.y() + 0.5 * kThick, 0)};
      for (int k = 0; k < 5; ++k)
      {
        Pose p;
        p.translation = centres[k];
        addBody(keep(std::make_unique<btBoxShape>(toBt(halves[k]))), toBt(p), 0.0, btVector3(0, 0, 0), settings);
      }
      entries_.push_back(e);
      return;
    }
    if (b.kind != Kind::Free)
    {
      btCollisionShape* shape = keep(std::make_unique<btBoxShape>(toBt(0.5 * b.size)));
      e.body = addBody(shape, toBt(b.pose), 0.0, btVector3(0, 0, 0), settings, &e.motion);
      if (b.kind == Kind::Scripted)
      {
        e.body->setCollisionFlags(e.body->getCollisionFlags() | btCollisionObject::CF_KINEMATIC_OBJECT);
        e.body->setActivationState(DISABLE_DEACTIVATION);
      }
      entries_.push_back(e);
      return;
    }
    // A free body: the core's mass properties (kg, kg m^2 about the centre of mass), the shape
    // about the centre of mass. Bullet takes a diagonal inertia; every shape here has its
    // principal axes along the body axes.
    const MassProperties mp = massProperties(boundaryOf(b), b.name);
    const Mat3d& I = mp.inertia;
    if (std::abs(I(0, 1)) + std::abs(I(0, 2)) + std::abs(I(1, 2)) > 1e-9 * I.trace())
      throw std::runtime_error(b.name + ": the inertia is not diagonal in the body axes");
    btCollisionShape* shape = nullptr;
    if (b.shape == ShapeType::Box) shape = keep(std::make_unique<btBoxShape>(toBt(0.5 * b.size)));
    if (b.shape == ShapeType::Sphere) shape = keep(std::make_unique<btSphereShape>(btScalar(b.radius)));
    if (b.shape == ShapeType::Mesh)
    {
      auto hull = std::make_unique<btConvexHullShape>();
      for (const Vec3d& v : b.mesh.vertices) hull->addPoint(toBt(v - mp.com), false);
      hull->recalcLocalAabb();
      shape = keep(std::move(hull));
    }
    Pose at_com = b.pose;
    at_com.translation = b.pose.apply(mp.com);
    e.body = addBody(shape, toBt(at_com), mp.mass, toBt(I.diagonal()), settings);
    e.body->setLinearVelocity(toBt(b.velocity));
    if (settings.ccd)
    {
      // Swept-sphere CCD when a step moves the body more than half its smallest half-size.
      const double r = b.shape == ShapeType::Sphere ? b.radius : 0.5 * b.size.minCoeff();
      e.body->setCcdMotionThreshold(btScalar(0.5 * r));
      e.body->setCcdSweptSphereRadius(btScalar(0.8 * r));
    }
    entries_.push_back(e);
  }

  btDefaultCollisionConfiguration config_;
  btCollisionDispatcher dispatcher_;
  btDbvtBroadphase broadphase_;
  btSequentialImpulseConstraintSolver solver_;
  btDiscreteDynamicsWorld world_;
  std::vector<Spec> specs_;
  std::vector<std::unique_ptr<btCollisionShape>> shapes_;
  std::vector<std::unique_ptr<btDefaultMotionState>> motions_;
  std::vector<std::unique_ptr<btRigidBody>> owned_;
  std::vector<Entry> entries_;  // per spec
};

using Factory = std::function<std::unique_ptr<Engine>(const std::vector<Spec>&)>;

// ---------------------------------------------------------------------------------- scenarios

struct Result
{
  std::string text;
  double us_per_step = 0.0;  // microseconds of wall clock per step
  std::size_t particles = 0;
};

/// Steps `engine` until `duration` (s), timing the steps only, calling `observe` after each.
double run(Engine& engine, double duration, const std::function<void()>& observe)
{
  double seconds = 0.0;
  long steps = 0;
  while (engine.time() < duration - 0.5 * kDt)
  {
    const auto t0 = Clock::now();
    engine.step();
    seconds += std::chrono::duration<double>(Clock::now() - t0).count();
    ++steps;
    observe();
  }
  return 1e6 * seconds / double(steps);
}

std::string format(const char* fmt, ...) __attribute__((format(printf, 1, 2)));
std::string format(const char* fmt, ...)
{
  char buf[512];
  va_list args;
  va_start(args, fmt);
  std::vsnprintf(buf, sizeof buf, fmt, args);
  va_end(args);
  return buf;
}

/// Tilt of the body's z axis from the world's, rad.
double tilt(const State& s)
{
  return std::acos(std::clamp((s.rotation * Vec3d::UnitZ()).z(), -1.0, 1.0));
}

/// Mean, standard deviation (Welford's update: no cancellation for a small spread about a large
/// mean), smallest and largest of samples.
struct Stats
{
  double mean_ = 0.0, m2 = 0.0, min = 1e300, max = -1e300;
  long n = 0;
  void add(double x)
  {
    ++n;
    const double d = x - mean_;
    mean_ += d / double(n);
    m2 += d * (x - mean_);
    min = std::min(min, x);
    max = std::max(max, x);
  }
  double mean() const
  {
    return mean_;
  }
  double stddev() const
  {
    return n ? std::sqrt(m2 / double(n)) : 0.0;
  }
};

/// Body `index` of `specs` dropped from just above its rest height `z_rest` (m, of its centre of
/// mass) and watched for 2 s: over the last second its height error (mean, mm and spacings), its
/// jitter (standard deviation of the height), its largest speed and its tilt.
Result rest(const Factory& make, const std::vector<Spec>& specs, std::size_t index, double z_rest, double s)
{
  auto engine = make(specs);
  Stats z, speed;
  double tilt_max = 0.0;
  const double us = run(*engine, 2.0, [&] {
    if (engine->time() < 1.0) return;
    const State st = engine->state(index);
    z.add(st.com.z());
    speed.add(st.v.norm());
    tilt_max = std::max(tilt_max, tilt(st));
  });
  const double err = z.mean() - z_rest;  // m
  return {format("height %+.3f mm (%+.3f s), jitter %.1e m, speed <= %.1e m/s, tilt %.1e rad", 1e3 * err, err / s,
                 z.stddev(), speed.max, tilt_max),
          us, engine->particles()};
}

Result boxRest(const Factory& make, double s, bool half_offset)
{
  // Box 8 x 8 x 4 cm of 2000 kg/m^3, 2 mm above a dry floor. Its layer is the floor's lattice
  // shifted by nothing (aligned) or by half a spacing in x and y (diagonal: the deepest nest).
  const Vec3d c = Vec3d(0.2, 0.2, 0.022) + (half_offset ? Vec3d(0.5 * s, 0.5 * s, 0.0) : Vec3d::Zero());
  return rest(make,
              {tank(Vec3d(0.4, 0.4, 0.2)),
               box("box", Kind::Free, Vec3d(0.08, 0.08, 0.04), c, Eigen::Quaterniond::Identity(), 2000.0)},
              1, 0.02, s);
}

Result sphereRest(const Factory& make, double s)
{
  return rest(make, {tank(Vec3d(0.4, 0.4, 0.2)), sphere("ball", 0.03, Vec3d(0.2, 0.2, 0.032), 2000.0)}, 1, 0.03, s);
}

Result meshRest(const Factory& make, double s, const TriangleMesh& prism)
{
  // The octagonal prism of meshes/octagon_tank.stl at a quarter of its size (radius 7.5 cm to
  // the corners, 10 cm high, its base at z = 0 of its frame), 2 mm above the floor.
  Spec m;
  m.name = "prism";
  m.shape = ShapeType::Mesh;
  m.mesh = prism;
  m.pose.translation = Vec3d(0.2, 0.2, 0.002);
  return rest(make, {tank(Vec3d(0.4, 0.4, 0.2)), m}, 1, 0.05, s);
}

Result stack(const Factory& make, double s)
{
  // Three boxes 10 x 10 x 4 cm of 1000 kg/m^3, each 0.5 mm above the one below and shifted
  // sideways by a few millimetres (off every lattice), for 3 s. Over the last second: each box's
  // height error (bottom / middle / top), the top's jitter and the largest speed; at the end the
  // largest sideways drift.
  const double gap = 0.0005;  // m
  const std::vector<Vec3d> start = {Vec3d(0.2, 0.2, 0.02 + gap), Vec3d(0.2037, 0.2, 0.06 + 2 * gap),
                                    Vec3d(0.2071, 0.203, 0.10 + 3 * gap)};
  std::vector<Spec> specs = {tank(Vec3d(0.4, 0.4, 0.2))};
  for (int k = 0; k < 3; ++k)
    specs.push_back(box("box" + std::to_string(k), Kind::Free, Vec3d(0.1, 0.1, 0.04), start[k]));
  auto engine = make(specs);
  Stats bottom, middle, top, speed;
  const double us = run(*engine, 3.0, [&] {
    if (engine->time() < 2.0) return;
    bottom.add(engine->state(1).com.z() - 0.02);
    top.add(engine->state(3).com.z() - 0.10);
    middle.add(engine->state(2).com.z() - 0.06);
    for (int k = 1; k <= 3; ++k) speed.add(engine->state(k).v.norm());
  });
  double drift = 0.0;  // m, horizontal, largest of the three at the end
  for (int k = 0; k < 3; ++k)
    drift = std::max(drift, (engine->state(std::size_t(k + 1)).com - start[std::size_t(k)]).head<2>().norm());
  return {format("heights %+.3f / %+.3f / %+.3f mm (top %+.2f s), top jitter %.1e m, drift %.3f mm, speed <= %.1e m/s",
                 1e3 * bottom.mean(), 1e3 * middle.mean(), 1e3 * top.mean(), top.mean() / s, top.stddev(), 1e3 * drift,
                 speed.max),
          us, engine->particles()};
}

Result push(const Factory& make)
{
  // A paddle 4 cm thick (x), 1 cm above the floor, moves at 0.2 m/s along x and meets a box
  // 6 x 6 x 4 cm and a ball of radius 3 cm (both 800 kg/m^3) 2 cm ahead of it; 2 s. Reported:
  // how far each reached into the paddle's volume, whether one got behind it, and the box's
  // height error while pushed (after 0.5 s).
  const double speed = 0.2, half = 0.02;  // m/s; m, the paddle's half thickness
  Spec paddle = box("paddle", Kind::Scripted, Vec3d(2 * half, 0.36, 0.08), Vec3d(0.08, 0.2, 0.05));
  paddle.velocity = Vec3d(speed, 0, 0);
  const std::vector<Spec> specs = {
      tank(Vec3d(0.8, 0.4, 0.2)), paddle,
      box("box", Kind::Free, Vec3d(0.06, 0.06, 0.04), Vec3d(0.15, 0.12, 0.0205), Eigen::Quaterniond::Identity(), 800.0),
      sphere("ball", 0.03, Vec3d(0.15, 0.28, 0.0305), 800.0)};
  auto engine = make(specs);
  double pen_box = -1e9, pen_ball = -1e9;  // m, largest overlap with the paddle's volume
  bool through = false;
  Stats box_z;
  const double us = run(*engine, 2.0, [&] {
    const double front = 0.08 + half + speed * engine->time();  // m, the paddle's front face
    const State b = engine->state(2), ball = engine->state(3);
    double back = 1e9;  // m, the box's rearmost corner at the paddle's height (0.01-0.09 m)
    for (int k = 0; k < 8; ++k)
    {
      const Vec3d corner = b.com + b.rotation * Vec3d(k & 1 ? 0.03 : -0.03, k & 2 ? 0.03 : -0.03, k & 4 ? 0.02 : -0.02);
      if (corner.z() > 0.01 && corner.z() < 0.09) back = std::min(back, corner.x());
    }
    pen_box = std::max(pen_box, front - back);
    pen_ball = std::max(pen_ball, front - (ball.com.x() - 0.03));
    if (b.com.x() < front - 2 * half || ball.com.x() < front - 2 * half) through = true;
    if (engine->time() > 0.5) box_z.add(b.com.z() - 0.02);
  });
  return {format("overlap with paddle: box %.2f mm, ball %.2f mm; through: %s; box height %+.3f mm (min %+.3f)",
                 1e3 * std::max(0.0, pen_box), 1e3 * std::max(0.0, pen_ball), through ? "YES" : "no",
                 1e3 * box_z.mean(), 1e3 * box_z.min),
          us, engine->particles()};
}

Result fastSphere(const Factory& make, double s, double speed)
{
  // A ball of radius 2 cm (1000 kg/m^3) at `speed` (m/s) along x at a free-standing wall two
  // spacings thick, 30 x 30 cm; 0.1 s. Run from kPhases starts, a fraction of one step's travel
  // apart along x and of a spacing along y, so that the last step before the wall ends at every
  // distance from it and the ball meets every part of the wall's lattice: a pass through any of
  // them counts. Reported: passes, the deepest overlap with the wall's volume and the fastest
  // rebound (restitution is 0).
  constexpr int kPhases = 8;
  const double wall_x = 0.3, r = 0.02;  // m: the wall's centre, the ball's radius
  const Spec wall = box("wall", Kind::Static, Vec3d(2 * s, 0.3, 0.3), Vec3d(wall_x, 0, 0.3));
  int through = 0;
  double overlap = 0.0, rebound = 0.0, us = 0.0;  // m into the wall's front; m/s back along -x
  std::size_t particles = 0;
  for (int k = 0; k < kPhases; ++k)
  {
    const double f = double(k) / kPhases;
    Spec ball = sphere("ball", r, Vec3d(0.1 - f * speed * kDt, f * s, 0.3), 1000.0);
    ball.velocity = Vec3d(speed, 0, 0);
    auto engine = make({wall, ball});
    us += run(*engine, 0.1,
              [&] {
                const State b = engine->state(1);
                if (b.com.x() < wall_x) overlap = std::max(overlap, b.com.x() + r - (wall_x - s));
                rebound = std::max(rebound, -b.v.x());
              }) /
          kPhases;
    if (engine->state(1).com.x() > wall_x) ++through;
    particles = engine->particles();
  }
  return {format("through: %d of %d starts; overlap <= %.2f mm (%.2f s), rebound <= %.2f m/s", through, kPhases,
                 1e3 * overlap, overlap / s, rebound),
          us, particles};
}

Result incline(const Factory& make, double degrees, double yaw_degrees)
{
  // A box 10 x 10 x 4 cm (1000 kg/m^3) on a plank 1.6 x 0.3 x 0.05 m tilted by `degrees` about
  // y, released 0.5 mm above it near the upper end, turned by `yaw_degrees` about the plank's
  // normal (0: its edges and lattice along the plank's); 1 s. Its travel d down the slope is
  // fitted with d0 + v0 t + a t^2 / 2 over 0.2-1 s, or until it has travelled 1.2 m (the plank
  // ends at 1.5 m). Coulomb: a block slides when tan(angle) > mu, at a = g (sin - mu cos).
  const double angle = degrees * M_PI / 180.0, yaw = yaw_degrees * M_PI / 180.0;  // rad
  const Eigen::Quaterniond q(Eigen::AngleAxisd(angle, Vec3d::UnitY()));
  const Vec3d plank_c(0, 0, 0.6), down = q * Vec3d::UnitX(), normal = q * Vec3d::UnitZ();
  const Vec3d start = plank_c + q * Vec3d(-0.7, 0, 0.025 + 0.02 + 0.0005);
  const std::vector<Spec> specs = {box("plank", Kind::Static, Vec3d(1.6, 0.3, 0.05), plank_c, q),
                                   box("box", Kind::Free, Vec3d(0.1, 0.1, 0.04), start,
                                       q * Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Vec3d::UnitZ())))};
  auto engine = make(specs);
  Eigen::Matrix3d normal_m = Eigen::Matrix3d::Zero();  // least squares in (1, t, t^2 / 2)
  Vec3d rhs = Vec3d::Zero();
  Stats height;
  bool left = false;                  // travelled past 1.2 m
  double travel = 0.0, window = 0.0;  // m, s: at the fit's last sample
  const double us = run(*engine, 1.0, [&] {
    const State b = engine->state(1);
    const double t = engine->time(), d = (b.com - start).dot(down);
    if (t < 0.2 || d > 1.2 || left)
    {
      left = left || d > 1.2;
      return;
    }
    travel = d;
    window = t;
    const Vec3d basis(1.0, t, 0.5 * t * t);
    normal_m += basis * basis.transpose();
    rhs += d * basis;
    height.add((b.com - plank_c).dot(normal) - 0.045);
  });
  const double a = normal_m.ldlt().solve(rhs).z();                                        // m/s^2
  const double expected = std::max(0.0, kG * (std::sin(angle) - kMu * std::cos(angle)));  // m/s^2
  return {format("travel %.1f mm in %.2f s, a %.3f m/s^2 (g(sin - mu cos): %s), height %+.3f mm", 1e3 * travel, window,
                 a, expected > 0.0 ? format("%.3f", expected).c_str() : "sticks", 1e3 * height.mean()),
          us, engine->particles()};
}

struct Row
{
  std::string scenario;
  double spacing = 0.0;  // m
  std::string engine;
  Result result;
};

void printRow(const Row& r)
{
  std::printf("%-24s %5.1f  %-11s %9.1f %7zu  %s\n", r.scenario.c_str(), 100.0 * r.spacing, r.engine.c_str(),
              r.result.us_per_step, r.result.particles, r.result.text.c_str());
  std::fflush(stdout);
}
}  // namespace

int main(int argc, char** argv)
{
  CLI::App app{"Dry rigid-body contacts: the particle contacts (ContactSolver) against Bullet's"};
  std::vector<double> spacings;
  std::vector<std::string> scenarios;
  int threads = 1;
  BulletSettings bullet;
  std::vector<double> angles = {20.0, 35.0};       // degrees: below and above atan(0.5) = 26.6
  std::vector<double> yaws = {0.0, 45.0};          // degrees
  std::vector<double> speeds = {5.0, 10.0, 20.0};  // m/s
  std::string mesh_path = std::string(FLUID_SIM_SOURCE_DIR) + "/meshes/octagon_tank.stl";
  const std::vector<std::string> all = {"box_rest", "box_rest_offset", "sphere_rest", "stack",
                                        "push",     "fast_sphere",     "incline",     "mesh_rest"};
  app.add_option("--spacing", spacings, "particle spacing(s), m (default: 0.01 and 0.02)")->check(CLI::PositiveNumber);
  app.add_option("--scenario", scenarios, "scenario(s) to run (default: all)")->check(CLI::IsMember(all));
  app.add_option("--threads", threads, "worker threads of the core (0 = all cores; default 1, as Bullet)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--margin", bullet.margin, "Bullet's collision margin of every shape, m")->check(CLI::PositiveNumber);
  app.add_option("--iterations", bullet.iterations, "Bullet's solver iterations")->check(CLI::PositiveNumber);
  app.add_option("--friction", kMu, "Coulomb friction coefficient of both engines")->check(CLI::NonNegativeNumber);
  app.add_option("--angle", angles, "incline angle(s), degrees (default: 20 and 35)")->check(CLI::Range(0.0, 80.0));
  app.add_option("--speed", speeds, "fast sphere speed(s), m/s (default: 5, 10 and 20)")->check(CLI::PositiveNumber);
  app.add_option("--yaw", yaws, "the box's turn on the incline, degrees (default: 0 and 45)");
  app.add_option("--mesh", mesh_path, "closed mesh for mesh_rest (scaled by 0.25)");
  CLI11_PARSE(app, argc, argv);
  if (spacings.empty()) spacings = {0.01, 0.02};
  if (scenarios.empty()) scenarios = all;

  std::unique_ptr<tbb::global_control> thread_limit;
  if (threads > 0)
    thread_limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                         static_cast<std::size_t>(threads));
  const std::size_t active = tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism);

  std::printf(
      "fluid_sim_contact_bench: dt %.0f ms, g %.2f m/s^2, mu %.2f, restitution 0; core Real = %s, %zu thread(s); "
      "Bullet %d.%02d (btScalar %s), margin %.1f mm, %d iterations, no sleeping\n",
      1e3 * kDt, kG, kMu, sizeof(Real) == 4 ? "float" : "double", active, btGetVersion() / 100, btGetVersion() % 100,
      sizeof(btScalar) == 4 ? "float" : "double", 1e3 * bullet.margin, bullet.iterations);
  std::printf("%-24s %5s  %-11s %9s %7s  %s\n", "scenario", "s/cm", "engine", "us/step", "bparts", "result");

  TriangleMesh prism;
  const auto needs = [&](const std::string& name) {
    return std::find(scenarios.begin(), scenarios.end(), name) != scenarios.end();
  };
  if (needs("mesh_rest"))
  {
    const io::MeshFile file = io::readMeshFile(mesh_path, Vec3d::Constant(0.25));
    if (!file.closed) throw std::runtime_error(mesh_path + " is not a closed mesh");
    prism = file.mesh;
  }

  for (const double s : spacings)
  {
    BulletSettings with_ccd = bullet;
    with_ccd.ccd = true;
    const std::vector<std::pair<std::string, Factory>> engines = {
        {"particles", [s](const std::vector<Spec>& specs) { return std::make_unique<ParticleEngine>(specs, s); }},
        {"bullet", [bullet](const std::vector<Spec>& specs) { return std::make_unique<BulletEngine>(specs, bullet); }}};
    const Factory ccd = [with_ccd](const std::vector<Spec>& specs) {
      return std::make_unique<BulletEngine>(specs, with_ccd);
    };
    for (const std::string& name : scenarios)
      for (const auto& [engine, make] : engines)
      {
        if (name == "box_rest") printRow({"box rest (aligned)", s, engine, boxRest(make, s, false)});
        if (name == "box_rest_offset") printRow({"box rest (half offset)", s, engine, boxRest(make, s, true)});
        if (name == "sphere_rest") printRow({"sphere rest", s, engine, sphereRest(make, s)});
        if (name == "mesh_rest") printRow({"mesh rest (octagon)", s, engine, meshRest(make, s, prism)});
        if (name == "stack") printRow({"stack of 3 boxes", s, engine, stack(make, s)});
        if (name == "push") printRow({"paddle push 0.2 m/s", s, engine, push(make)});
        if (name == "fast_sphere")
          for (const double v : speeds)
          {
            const std::string label = format("fast sphere %.0f m/s", v);
            printRow({label, s, engine, fastSphere(make, s, v)});
            if (engine == "bullet") printRow({label, s, "bullet+ccd", fastSphere(ccd, s, v)});
          }
        if (name == "incline")
          for (const double yaw : yaws)
            for (const double deg : angles)
              printRow({format("incline %.0f deg, yaw %.0f", deg, yaw), s, engine, incline(make, deg, yaw)});
      }
  }
  return 0;
}
