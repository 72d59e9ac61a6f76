// Contacts between bodies by Bullet (docs/method.md, Free bodies, Eqs. A26b, A27). Bullet is used
// for collision detection and its contact solver only: the free bodies' motion under gravity and
// the fluid (Eqs. A24, A25) and their positions are integrated by BodySet::stepFree in double
// precision; Bullet (single precision in Debian's build) receives the poses and velocities every
// step and returns velocity changes.

#include "fluid_sim/core/bullet_contacts.h"

#include <BulletCollision/CollisionShapes/btTriangleMesh.h>
#include <LinearMath/btConvexHullComputer.h>
#include <btBulletDynamicsCommon.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <vector>

#include "fluid_sim/core/bodies.h"

namespace fluid_sim
{
namespace
{
constexpr double kMaxMargin = 1e-3;  // m, collision margin (Bullet's default 4 cm is a body's size here)
// A box container's walls, outside its inner faces, are one particle layer's reach thick (the
// spacing, its layer lying half a spacing out): 10 cm slabs, 10 cm wider than the box, held a
// free cube 10 cm above a cup standing in a tank and kept bodies 5 cm off a neighbouring tank's
// wall. Thin walls hold: the free shapes are swept (continuous collision detection), and a 1 cm
// ball at 30 m/s stopped in a 1 cm wall.
constexpr double kMaxWallThickness = 0.1;  // m
constexpr int kSegments = 48;              // around a tessellated sphere or cylinder container

btVector3 toBt(const Vec3d& v)
{
  return btVector3(btScalar(v.x()), btScalar(v.y()), btScalar(v.z()));
}
Vec3d fromBt(const btVector3& v)
{
  return Vec3d(v.x(), v.y(), v.z());
}
/// v with each component rounded to btScalar (exactly what toBt(v) stores), m/s or rad/s.
Vec3d roundedToBt(const Vec3d& v)
{
  return Vec3d(double(btScalar(v.x())), double(btScalar(v.y())), double(btScalar(v.z())));
}
btTransform toBt(const Pose& p)
{
  const Eigen::Quaterniond q = p.rotation.normalized();
  return btTransform(btQuaternion(btScalar(q.x()), btScalar(q.y()), btScalar(q.z()), btScalar(q.w())),
                     toBt(p.translation));
}
/// a then b: x -> a.apply(b.apply(x)).
Pose compose(const Pose& a, const Pose& b)
{
  Pose out;
  out.rotation = a.rotation * b.rotation;
  out.translation = a.apply(b.translation);
  return out;
}
Pose inverse(const Pose& p)
{
  Pose out;
  out.rotation = p.rotation.conjugate();
  out.translation = -(out.rotation * p.translation);
  return out;
}

/// btDiscreteDynamicsWorld stepped one internal step at a time: stepSimulation() would derive the
/// kinematic bodies' velocities from the change of their poses and apply gravity, and here both
/// are given (BulletContacts::apply).
class World : public btDiscreteDynamicsWorld
{
public:
  using btDiscreteDynamicsWorld::btDiscreteDynamicsWorld;
  void singleStep(btScalar dt)
  {
    internalSingleStepSimulation(dt);
  }
};

/// A closed triangle surface of a sphere or cylinder container, body frame (m). Vertices lie
/// 1/cos(pi/kSegments) outside the surface, so that the faces' middles are on it.
TriangleMesh tessellate(const BoundaryConfig& b)
{
  TriangleMesh m;
  const double out = 1.0 / std::cos(M_PI / kSegments);
  if (b.type == ShapeType::Sphere)
  {
    const int rows = kSegments / 2;
    const double r = b.sphere.radius * out;
    m.vertices.push_back(b.sphere.center + Vec3d(0, 0, r));
    for (int i = 1; i < rows; ++i)
      for (int j = 0; j < kSegments; ++j)
      {
        const double th = M_PI * i / rows, ph = 2.0 * M_PI * j / kSegments;
        m.vertices.push_back(b.sphere.center +
                             r * Vec3d(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th)));
      }
    m.vertices.push_back(b.sphere.center - Vec3d(0, 0, r));
    const int south = int(m.vertices.size()) - 1;
    const auto at = [](int i, int j) { return 1 + (i - 1) * kSegments + (j % kSegments); };
    for (int j = 0; j < kSegments; ++j)
    {
      m.triangles.push_back({0, at(1, j), at(1, j + 1)});
      m.triangles.push_back({south, at(rows - 1, j + 1), at(rows - 1, j)});
      for (int i = 1; i + 1 < rows; ++i)
      {
        m.triangles.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
        m.triangles.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
      }
    }
    return m;
  }
  // Cylinder: two rings and the caps' centres, axis z, then turned to the axis.
  const CylinderShape& c = b.cylinder;
  const Eigen::Quaterniond turn = Eigen::Quaterniond::FromTwoVectors(Vec3d::UnitZ(), c.axis.normalized());
  const double r = c.radius * out, h = 0.5 * c.length;
  for (int end = 0; end < 2; ++end)
    for (int j = 0; j < kSegments; ++j)
    {
      const double ph = 2.0 * M_PI * j / kSegments;
      m.vertices.push_back(c.center + turn * Vec3d(r * std::cos(ph), r * std::sin(ph), end ? h : -h));
    }
  m.vertices.push_back(c.center - turn * Vec3d(0, 0, h));
  m.vertices.push_back(c.center + turn * Vec3d(0, 0, h));
  const int bottom = 2 * kSegments, top = bottom + 1;
  for (int j = 0; j < kSegments; ++j)
  {
    const int a = j, b2 = (j + 1) % kSegments;
    m.triangles.push_back({a, b2, kSegments + b2});
    m.triangles.push_back({a, kSegments + b2, kSegments + a});
    m.triangles.push_back({bottom, b2, a});
    m.triangles.push_back({top, kSegments + a, kSegments + b2});
  }
  return m;
}
}  // namespace

struct BulletContacts::Impl
{
  /// One Bullet object of a body: a free body has one; a static or moving body one per convex
  /// piece (a container's walls) or its triangle mesh. Bullet tests a compound's pieces against
  /// another body by their exact bounding boxes, and a body resting exactly on a piece then lost
  /// its contact in some steps (touching boxes, rounded, need not overlap) and fell for one step;
  /// separate objects are tested with Bullet's contact breaking threshold.
  struct Part
  {
    std::unique_ptr<btRigidBody> body;
    Pose frame;  // the object's frame in the body frame: principal axes at the centre of mass (free)
  };
  struct Entry
  {
    std::vector<Part> parts;
    bool free = false;
    bool moving = false;
    Vec3d v_given = Vec3d::Zero(), w_given = Vec3d::Zero();  // m/s, rad/s: as handed to Bullet
  };

  btDefaultCollisionConfiguration configuration;
  btCollisionDispatcher dispatcher{&configuration};
  btDbvtBroadphase broadphase;
  btSequentialImpulseConstraintSolver solver;
  World world{&dispatcher, &broadphase, &solver, &configuration};
  std::vector<std::unique_ptr<btCollisionShape>> shapes;
  std::vector<std::unique_ptr<btTriangleMesh>> meshes;
  std::vector<Entry> entries;                 // one per body
  double margin = kMaxMargin;                 // m
  double wall_thickness = kMaxWallThickness;  // m, a box container's walls (the spacing)
  std::size_t contacts = 0;

  ~Impl()
  {
    for (Entry& e : entries)
      for (Part& p : e.parts) world.removeRigidBody(p.body.get());
  }

  template <class Shape>
  Shape* keep(std::unique_ptr<Shape> shape)
  {
    Shape* raw = shape.get();
    shapes.push_back(std::move(shape));
    return raw;
  }

  /// Margin of a convex primitive whose smallest half-size is `half` (m): within it, at most a
  /// fifth of it.
  double marginFor(double half) const
  {
    return std::min(margin, 0.2 * half);
  }

  btCollisionShape* boxShape(const Vec3d& half)
  {
    auto* box = keep(std::make_unique<btBoxShape>(toBt(half)));
    box->setMargin(btScalar(marginFor(half.minCoeff())));  // inside the box: its faces are exact
    return box;
  }
  btCollisionShape* cylinderShape(const CylinderShape& c)
  {
    auto* cylinder = keep(std::make_unique<btCylinderShapeZ>(
        btVector3(btScalar(c.radius), btScalar(c.radius), btScalar(0.5 * c.length))));
    cylinder->setMargin(btScalar(marginFor(std::min(c.radius, 0.5 * c.length))));
    return cylinder;
  }

  btCollisionShape* triangleShape(const TriangleMesh& mesh)
  {
    auto tm = std::make_unique<btTriangleMesh>();
    for (const auto& t : mesh.triangles)
      tm->addTriangle(toBt(mesh.vertices[t[0]]), toBt(mesh.vertices[t[1]]), toBt(mesh.vertices[t[2]]));
    auto* shape = keep(std::make_unique<btBvhTriangleMeshShape>(tm.get(), true));
    shape->setMargin(btScalar(margin));
    meshes.push_back(std::move(tm));
    return shape;
  }

  /// The convex hull of `points` (m, in the object's frame), shrunk by the margin Bullet adds
  /// outside a hull, so that its surface is the points' hull.
  btCollisionShape* hullShape(const std::vector<Vec3d>& points)
  {
    std::vector<double> coords;
    for (const Vec3d& p : points) coords.insert(coords.end(), {p.x(), p.y(), p.z()});
    btConvexHullComputer hull;
    const btScalar shrunk =
        hull.compute(coords.data(), int(3 * sizeof(double)), int(points.size()), btScalar(margin), btScalar(0.25));
    auto* shape = keep(std::make_unique<btConvexHullShape>());
    for (int i = 0; i < hull.vertices.size(); ++i) shape->addPoint(hull.vertices[i], false);
    shape->recalcLocalAabb();
    shape->setMargin(std::max(shrunk, btScalar(0)));
    return shape;
  }

  /// A box, sphere or cylinder (not a container) as a Bullet primitive in its own frame: its
  /// centre, a cylinder's axis as z. Sets `own` (the frame in the body frame).
  btCollisionShape* primitive(const BoundaryConfig& b, Pose& own)
  {
    own = Pose();
    switch (b.type)
    {
      case ShapeType::Box:
        own.translation = 0.5 * (b.box.max + b.box.min);
        return boxShape(0.5 * (b.box.max - b.box.min));
      case ShapeType::Sphere:
        own.translation = b.sphere.center;
        return keep(std::make_unique<btSphereShape>(btScalar(b.sphere.radius)));  // all margin: exact
      case ShapeType::Cylinder:
        own.translation = b.cylinder.center;
        own.rotation = Eigen::Quaterniond::FromTwoVectors(Vec3d::UnitZ(), b.cylinder.axis.normalized());
        return cylinderShape(b.cylinder);
      case ShapeType::Mesh:
        break;
    }
    return nullptr;
  }

  /// A box container's six walls wall_thickness thick outside its inner faces, overlapping at the
  /// edges: (frame in the body frame, shape).
  std::vector<std::pair<Pose, btCollisionShape*>> walls(const AxisBox& box)
  {
    std::vector<std::pair<Pose, btCollisionShape*>> out;
    const Vec3d half = 0.5 * (box.max - box.min), mid = 0.5 * (box.max + box.min);
    for (int axis = 0; axis < 3; ++axis)
      for (int side = -1; side <= 1; side += 2)
      {
        Vec3d wall_half = half + Vec3d::Constant(wall_thickness);
        wall_half[axis] = 0.5 * wall_thickness;
        Pose at;
        at.translation = mid;
        at.translation[axis] += side * (half[axis] + 0.5 * wall_thickness);
        out.emplace_back(at, boxShape(wall_half));
      }
    return out;
  }

  /// A free body's shape in its principal frame `frame` (a pose in the body frame), one convex
  /// shape where it can be (Bullet's continuous collision detection skips compounds): the
  /// primitive itself when its own frame is principal (the centre of mass at its centre, the
  /// inertia diagonal in its axes; `frame` and `moments` are set to it then); otherwise the
  /// primitive's hull (a box's corners, a cylinder's rims at 48 points, a sphere as a one-sphere
  /// btMultiSphereShape) or a mesh's hull, placed in `frame`; a box container as a compound of its
  /// walls. Throws ConfigError for a free sphere, cylinder or mesh container.
  btCollisionShape* freeShape(const Body& body, Pose& frame, Vec3d& moments, const std::string& key)
  {
    const BoundaryConfig& b = body.config;
    if (!b.inside && b.type != ShapeType::Mesh)
    {
      Pose own;
      const double size = b.type == ShapeType::Box      ? (b.box.max - b.box.min).norm()
                          : b.type == ShapeType::Sphere ? b.sphere.radius
                                                        : std::max(b.cylinder.radius, b.cylinder.length);
      own.translation = b.type == ShapeType::Box      ? Vec3d(0.5 * (b.box.max + b.box.min))
                        : b.type == ShapeType::Sphere ? b.sphere.center
                                                      : b.cylinder.center;
      if (b.type == ShapeType::Cylinder)
        own.rotation = Eigen::Quaterniond::FromTwoVectors(Vec3d::UnitZ(), b.cylinder.axis.normalized());
      const Mat3d R = own.rotation.toRotationMatrix();
      const Mat3d I = R.transpose() * body.inertia_local * R;  // kg m^2, in the shape's axes
      const double tol = 1e-9 * I.trace();
      if ((body.com_local - own.translation).norm() <= 1e-9 * size && std::abs(I(0, 1)) <= tol &&
          std::abs(I(0, 2)) <= tol && std::abs(I(1, 2)) <= tol)
      {
        moments = I.diagonal();
        return primitive(b, frame);  // sets frame to `own`
      }
    }
    const Pose to_frame = inverse(frame);
    if (b.inside)
    {
      if (b.type != ShapeType::Box)
        throw ConfigError(key, "'" + b.name +
                                   "' is a free container; contacts.model bullet models a free container only as "
                                   "a box (use contacts.model: particles)");
      auto* compound = keep(std::make_unique<btCompoundShape>());
      for (const auto& [at, wall] : walls(b.box)) compound->addChildShape(toBt(compose(to_frame, at)), wall);
      compound->recalculateLocalAabb();
      return compound;
    }
    std::vector<Vec3d> points;  // m, body frame
    switch (b.type)
    {
      case ShapeType::Box:
        for (int k = 0; k < 8; ++k)
          points.push_back(Vec3d(k & 1 ? b.box.max.x() : b.box.min.x(), k & 2 ? b.box.max.y() : b.box.min.y(),
                                 k & 4 ? b.box.max.z() : b.box.min.z()));
        break;
      case ShapeType::Sphere:
      {
        const btVector3 centre = toBt(to_frame.apply(b.sphere.center));
        const btScalar radius = btScalar(b.sphere.radius);
        return keep(std::make_unique<btMultiSphereShape>(&centre, &radius, 1));
      }
      case ShapeType::Cylinder:
        points = tessellate(b).vertices;
        points.resize(2 * kSegments);  // the rims, not the caps' centres
        break;
      case ShapeType::Mesh:
        points = b.mesh.vertices;
        break;
    }
    for (Vec3d& p : points) p = to_frame.apply(p);
    return hullShape(points);
  }

  /// m, the radius of a sphere inside the body, for continuous collision detection.
  double innerRadius(const BoundaryConfig& b) const
  {
    switch (b.type)
    {
      case ShapeType::Box:
        return b.inside ? 0.5 * wall_thickness : 0.5 * (b.box.max - b.box.min).minCoeff();
      case ShapeType::Sphere:
        return b.sphere.radius;
      case ShapeType::Cylinder:
        return std::min(b.cylinder.radius, 0.5 * b.cylinder.length);
      case ShapeType::Mesh:
      {
        Vec3d lo = Vec3d::Constant(1e300), hi = Vec3d::Constant(-1e300);
        for (const Vec3d& v : b.mesh.vertices)
        {
          lo = lo.cwiseMin(v);
          hi = hi.cwiseMax(v);
        }
        return b.mesh.vertices.empty() ? 0.0 : 0.25 * (hi - lo).minCoeff();
      }
    }
    return 0.0;
  }

  btRigidBody* add(Entry& e, const Body& body, std::size_t index, btCollisionShape* shape, const Pose& frame,
                   double mass, const btVector3& inertia, btScalar friction)
  {
    btRigidBody::btRigidBodyConstructionInfo ci(btScalar(mass), nullptr, shape, inertia);
    ci.m_startWorldTransform = toBt(compose(body.pose, frame));
    ci.m_friction = friction;
    ci.m_rollingFriction = 0;
    ci.m_restitution = 0;
    ci.m_linearDamping = 0;
    ci.m_angularDamping = 0;
    Part part;
    part.body = std::make_unique<btRigidBody>(ci);
    part.frame = frame;
    btRigidBody& rb = *part.body;
    rb.setUserIndex(int(index));
    rb.setActivationState(DISABLE_DEACTIVATION);  // a body in water never sleeps
    if (e.moving) rb.setCollisionFlags(rb.getCollisionFlags() | btCollisionObject::CF_KINEMATIC_OBJECT);
    if (e.free) rb.setFlags(0);  // no gyroscopic term: Eq. A25 has it already
    world.addRigidBody(&rb);
    rb.setGravity(btVector3(0, 0, 0));  // gravity is in the velocities handed in (Eq. A24)
    e.parts.push_back(std::move(part));
    return &rb;
  }
};

BulletContacts::BulletContacts(const BodySet& bodies, double spacing, const ContactConfig& config)
    : impl_(std::make_unique<Impl>())
{
  Impl& m = *impl_;
  m.margin = std::min(kMaxMargin, 0.1 * spacing);
  m.wall_thickness = std::min(kMaxWallThickness, spacing);
  btDiscreteDynamicsWorld& world = m.world;
  world.setGravity(btVector3(0, 0, 0));
  btContactSolverInfo& info = world.getSolverInfo();
  // Every correction of overlap as velocity (Baumgarte, erp 0.2 of the overlap per step): the
  // positions are ours, Bullet's split-impulse position pass would be lost.
  info.m_splitImpulse = 0;
  // A fast body's sweep stops where it would overlap by more than the margin (Bullet's default:
  // 4 cm, the size of the bodies here).
  world.getDispatchInfo().m_allowedCcdPenetration = btScalar(m.margin);
  const btScalar friction = btScalar(std::sqrt(config.friction));  // Bullet multiplies the pair's
  for (std::size_t k = 0; k < bodies.size(); ++k)
  {
    const Body& body = bodies[k];
    const BoundaryConfig& b = body.config;
    const std::string key = boundaryKey(b, k) + " '" + b.name + "'";
    m.entries.emplace_back();
    Impl::Entry& e = m.entries.back();
    e.free = body.free;
    e.moving = body.moving && !body.free;
    if (!body.free)
    {
      // Static or kinematic: each convex piece an object of its own, in its own frame.
      if (b.type == ShapeType::Mesh)
        m.add(e, body, k, m.triangleShape(b.mesh), Pose(), 0.0, btVector3(0, 0, 0), friction);
      else if (b.inside && b.type == ShapeType::Box)
        for (const auto& [at, wall] : m.walls(b.box)) m.add(e, body, k, wall, at, 0.0, btVector3(0, 0, 0), friction);
      else if (b.inside)
        m.add(e, body, k, m.triangleShape(tessellate(b)), Pose(), 0.0, btVector3(0, 0, 0), friction);
      else
      {
        Pose own;
        btCollisionShape* shape = m.primitive(b, own);
        m.add(e, body, k, shape, own, 0.0, btVector3(0, 0, 0), friction);
      }
      continue;
    }
    // Free: the principal axes of the inertia (kg m^2, body axes, about the centre of mass),
    // I = Q diag(d) Q^T, the object's frame (com, Q) in the body frame, unless the shape's own
    // frame is principal (freeShape).
    const Mat3d& I = body.inertia_local;
    Mat3d Q = Mat3d::Identity();
    Vec3d d = I.diagonal();
    if (I(0, 1) != 0.0 || I(0, 2) != 0.0 || I(1, 2) != 0.0)
    {
      Eigen::SelfAdjointEigenSolver<Mat3d> eig(I);
      Q = eig.eigenvectors();
      d = eig.eigenvalues();
      if (Q.determinant() < 0.0) Q.col(2) = -Q.col(2);
    }
    Pose frame;
    frame.rotation = Eigen::Quaterniond(Q).normalized();
    frame.translation = body.com_local;
    btCollisionShape* shape = m.freeShape(body, frame, d, key);
    btRigidBody* rb = m.add(e, body, k, shape, frame, body.mass, toBt(d), friction);
    // Continuous collision detection when a step moves the body by more than half the radius of
    // a sphere inside it: a speculative contact from the swept sphere.
    const double r = m.innerRadius(b);
    // Rolling resistance: Bullet combines two bodies' values as rolling_a friction_b + rolling_b
    // friction_a (a lever, m), so the free body's own value divided by the other's friction sqrt(mu)
    // gives the lever rolling_resistance r against a kinematic body (and the levers' sum between
    // two free bodies). Without it a cylinder lying on the floor starts rolling by itself and
    // speeds up, in a plain Bullet world too (docs/method_notes.md, Free bodies). Not for a box,
    // which cannot roll: there the extra constraints only stir a resting stack (late speed 6e-4
    // instead of 2e-4 m/s).
    if (friction > 0 && b.type != ShapeType::Box)
      rb->setRollingFriction(btScalar(config.rolling_resistance * r) / friction);
    if (r > 0.0)
    {
      rb->setCcdMotionThreshold(btScalar(0.5 * r));
      rb->setCcdSweptSphereRadius(btScalar(r));
    }
  }
}

BulletContacts::~BulletContacts() = default;

std::size_t BulletContacts::contacts() const
{
  return impl_->contacts;
}

double BulletContacts::margin() const
{
  return impl_->margin;
}

void BulletContacts::apply(BodySet& bodies, double dt)
{
  Impl& m = *impl_;
  // Poses at the step's start; the free bodies' velocities after gravity and the fluid (Eqs. A24,
  // A25), the moving bodies' own (Eq. A17; Bullet's velocity of a kinematic object is that of its
  // frame's origin).
  for (std::size_t k = 0; k < bodies.size(); ++k)
  {
    Body& body = bodies[k];
    Impl::Entry& e = m.entries[k];
    body.contact_force.setZero();
    if (e.free)
    {
      btRigidBody& rb = *e.parts.front().body;
      rb.setCenterOfMassTransform(toBt(compose(body.pose, e.parts.front().frame)));
      // Rounded to Bullet's precision here, not read back from the body: in this build (GCC 12,
      // -O2 -march=native) such a read-back gave the unrounded doubles, so that a body without
      // contacts gained the rounding error, 3e-8 m/s per step (cause not pinned down).
      e.v_given = roundedToBt(body.v_com);
      e.w_given = roundedToBt(body.omega);
      rb.setLinearVelocity(toBt(e.v_given));
      rb.setAngularVelocity(toBt(e.w_given));
    }
    else if (e.moving)
      for (Impl::Part& part : e.parts)
      {
        const Pose at = compose(body.pose, part.frame);
        const btTransform t = toBt(at);
        part.body->setWorldTransform(t);
        part.body->setInterpolationWorldTransform(t);
        part.body->setLinearVelocity(toBt(body.v_origin + body.omega.cross(at.translation - body.pose.translation)));
        part.body->setAngularVelocity(toBt(body.omega));
      }
  }
  m.world.singleStep(btScalar(dt));
  // Eq. A26b: the free bodies' velocities change by what Bullet's contacts changed (exactly zero
  // for a body without contacts: Bullet adds nothing else).
  for (std::size_t k = 0; k < bodies.size(); ++k)
  {
    Impl::Entry& e = m.entries[k];
    if (!e.free) continue;
    Body& body = bodies[k];
    const btRigidBody& rb = *e.parts.front().body;
    const Vec3d dv = fromBt(rb.getLinearVelocity()) - e.v_given;   // m/s
    const Vec3d dw = fromBt(rb.getAngularVelocity()) - e.w_given;  // rad/s
    body.v_com += dv;
    body.omega += dw;
    body.contact_force = body.mass * dv / dt;  // Eq. A27, N
  }
  // Eq. A27 for static and moving bodies: the reaction to the impulses of their contact points.
  m.contacts = 0;
  for (int i = 0; i < m.dispatcher.getNumManifolds(); ++i)
  {
    const btPersistentManifold* pm = m.dispatcher.getManifoldByIndexInternal(i);
    m.contacts += std::size_t(pm->getNumContacts());
    const int a = pm->getBody0()->getUserIndex(), b = pm->getBody1()->getUserIndex();
    const bool a_kin = !m.entries[std::size_t(a)].free, b_kin = !m.entries[std::size_t(b)].free;
    if (!a_kin && !b_kin) continue;
    Vec3d j = Vec3d::Zero();  // N s, on body 0
    for (int p = 0; p < pm->getNumContacts(); ++p)
    {
      const btManifoldPoint& cp = pm->getContactPoint(p);
      j += fromBt(cp.m_normalWorldOnB) * cp.m_appliedImpulse +
           fromBt(cp.m_lateralFrictionDir1) * cp.m_appliedImpulseLateral1 +
           fromBt(cp.m_lateralFrictionDir2) * cp.m_appliedImpulseLateral2;
    }
    if (a_kin) bodies[std::size_t(a)].contact_force += j / dt;
    if (b_kin) bodies[std::size_t(b)].contact_force -= j / dt;
  }
}

}  // namespace fluid_sim
