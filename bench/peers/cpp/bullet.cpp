// Bullet 3 pipelines of vadop's peer benchmark, each as a Bullet user would assemble it, on
// either scene:
//  bullet-dbvt  discrete: btCollisionWorld + btDbvtBroadphase, overlaps at frame instants;
//  bullet-sap   discrete: the same with bt32BitAxisSweep3 (the 16-bit btAxisSweep3 holds at most
//               16383 objects, too few for this benchmark; the algorithm is the same);
//  bullet-ccd   continuous: a btDbvt over each body's swept box (leaves reinserted every frame),
//               its self-collision (each overlapping pair once), then Bullet's convex cast on each
//               pair for the time of impact: btGjkConvexCast for the spheres (linear motion),
//               btContinuousConvexCollision for the spinning shapes (linear and angular motion).
// Debian builds Bullet in single precision, so positions are rounded to float inside Bullet.
#include <btBulletCollisionCommon.h>
#include <BulletCollision/NarrowPhaseCollision/btContinuousConvexCollision.h>
#include <BulletCollision/NarrowPhaseCollision/btGjkConvexCast.h>
#include <BulletCollision/NarrowPhaseCollision/btGjkEpaPenetrationDepthSolver.h>
#include <BulletCollision/NarrowPhaseCollision/btVoronoiSimplexSolver.h>
#include <memory>
#include "trajectory.h"

static btVector3 vec(const double p[3]) { return btVector3(btScalar(p[0]), btScalar(p[1]), btScalar(p[2])); }

static btTransform at(const double p[3]) {
  btTransform transform;
  transform.setIdentity();
  transform.setOrigin(vec(p));
  return transform;
}

// The sphere scene's bodies as Bullet sees them: one sphere shape, placed by its centre.
struct SphereBodies {
  explicit SphereBodies(Trajectory& paths) : paths(paths), sphere(btScalar(paths.radius)) {}

  btCollisionShape* shape(uint64_t) { return &sphere; }
  btTransform at_start(uint64_t i) const { return at(paths.start(i)); }
  btTransform at_end(uint64_t i) const { return at(paths.end(i)); }

  // btGjkConvexCast over each piece of the frame in which both move in a straight line.
  bool new_contact(uint64_t i, uint64_t j) {
    auto cast = [&](const double a0[3], const double a1[3], const double b0[3], const double b1[3], double& fraction) {
      btGjkConvexCast caster(&sphere, &sphere, &simplex);
      btConvexCast::CastResult result;
      if (!caster.calcTimeOfImpact(at(a0), at(a1), at(b0), at(b1), result)) return false;
      fraction = result.m_fraction;
      return true;
    };
    return paths.new_contact(i, j, cast);
  }

  Trajectory& paths;
  btSphereShape sphere;
  btVoronoiSimplexSolver simplex;
};

// A convex shape moved by `offset` in its own frame. Bullet turns a shape about its own origin
// (its casts move the transform's origin in a straight line), so a shape whose centre of mass
// lies elsewhere (a cone) is wrapped to put that centre at the origin.
class Shifted final : public btConvexInternalShape {
 public:
  Shifted(std::unique_ptr<btConvexShape> inner, const btVector3& offset) : inner_(std::move(inner)), offset_(offset) {
    m_shapeType = CUSTOM_CONVEX_SHAPE_TYPE;
    setMargin(0);
  }
  btVector3 localGetSupportingVertexWithoutMargin(const btVector3& direction) const override {
    return inner_->localGetSupportingVertexWithoutMargin(direction) + offset_;
  }
  void batchedUnitVectorGetSupportingVertexWithoutMargin(const btVector3* directions, btVector3* out, int count) const override {
    for (int k = 0; k < count; ++k) out[k] = localGetSupportingVertexWithoutMargin(directions[k]);
  }
  // Only the detection runs here: no body needs an inertia.
  void calculateLocalInertia(btScalar, btVector3& inertia) const override { inertia.setZero(); }
  const char* getName() const override { return "Shifted"; }

 private:
  std::unique_ptr<btConvexShape> inner_;
  btVector3 offset_;
};

// A scene shape as a Bullet shape about its centre of mass. Margins are 0 where Bullet adds one
// (it would round boxes' and cylinders' edges and grow cones and hulls by 0.04); a sphere's and a
// capsule's margin is their radius, which is exact.
static std::unique_ptr<btConvexShape> bullet_shape(const ShapeSpec& spec) {
  const double* size = spec.size;
  btVector3 centre = vec(spec.centre);
  std::unique_ptr<btConvexShape> shape;
  switch (spec.kind) {
    case Kind::Sphere:
      shape.reset(new btSphereShape(btScalar(size[0])));
      break;
    case Kind::Cuboid:
      shape.reset(new btBoxShape(vec(size)));
      break;
    case Kind::Capsule:
      shape.reset(new btCapsuleShape(btScalar(size[1]), btScalar(2 * size[0])));
      break;
    case Kind::Cylinder:
      shape.reset(new btCylinderShape(btVector3(btScalar(size[1]), btScalar(size[0]), btScalar(size[1]))));
      break;
    case Kind::Cone:
      shape.reset(new btConeShape(btScalar(size[1]), btScalar(2 * size[0])));
      break;
    case Kind::ConvexHull: {
      // Its points about the centre of mass: no wrapper needed.
      auto hull = new btConvexHullShape();
      for (size_t k = 0; k < spec.vertices.size(); k += 3) hull->addPoint(vec(&spec.vertices[k]) - centre, false);
      hull->recalcLocalAabb();
      shape.reset(hull);
      centre.setZero();
      break;
    }
    default:
      throw std::runtime_error("unknown shape kind");
  }
  if (spec.kind != Kind::Sphere && spec.kind != Kind::Capsule) shape->setMargin(0);
  if (centre.isZero()) return shape;
  return std::unique_ptr<btConvexShape>(new Shifted(std::move(shape), -centre));
}

// The mixed-shape scene's bodies as Bullet sees them: each placed by its centre of mass, the
// origin of its Bullet shape.
struct ShapeBodies {
  explicit ShapeBodies(ShapeTrajectory& paths) : paths(paths) {
    for (const ShapeSpec& spec : paths.shapes) shapes.push_back(bullet_shape(spec));
  }

  btCollisionShape* shape(uint64_t i) { return convex(i); }
  btTransform at_start(uint64_t i) const { return placed(i, paths.start(i)); }
  btTransform at_end(uint64_t i) const { return placed(i, paths.end(i)); }

  // btContinuousConvexCollision: conservative advancement under the linear and angular motion
  // that takes each body from its start transform to its end one.
  bool new_contact(uint64_t i, uint64_t j) {
    btContinuousConvexCollision cast(convex(i), convex(j), &simplex, &penetration);
    btConvexCast::CastResult result;
    return cast.calcTimeOfImpact(at_start(i), at_end(i), at_start(j), at_end(j), result) && result.m_fraction > 0;
  }

  ShapeTrajectory& paths;
  std::vector<std::unique_ptr<btConvexShape>> shapes;
  btVoronoiSimplexSolver simplex;
  btGjkEpaPenetrationDepthSolver penetration;

 private:
  btConvexShape* convex(uint64_t i) { return shapes[paths.shape_of[i]].get(); }
  btTransform placed(uint64_t i, const State& state) const {
    double centre[3];
    paths.centre_of_mass(i, state, centre);
    const double* q = state.orientation;
    return btTransform(btQuaternion(btScalar(q[0]), btScalar(q[1]), btScalar(q[2]), btScalar(q[3])), vec(centre));
  }
};

template <class Bodies>
static void discrete(btBroadphaseInterface* broadphase, Bodies& bodies, Report& report) {
  auto& paths = bodies.paths;
  btDefaultCollisionConfiguration configuration;
  btCollisionDispatcher dispatcher(&configuration);
  btCollisionWorld world(&dispatcher, broadphase, &configuration);
  std::vector<std::unique_ptr<btCollisionObject>> objects(paths.n);
  // Objects enter the world at their first frame's start: all at the origin, every pair would
  // overlap once.
  bool loaded = paths.next_frame();
  for (uint64_t i = 0; i < paths.n; ++i) {
    objects[i].reset(new btCollisionObject());
    objects[i]->setCollisionShape(bodies.shape(i));
    objects[i]->setUserIndex(int(i));
    objects[i]->setWorldTransform(bodies.at_start(i));
    world.addCollisionObject(objects[i].get());
  }
  NewOverlaps overlaps;
  for (; loaded; loaded = paths.next_frame()) {
    report.begin_frame();
    for (uint64_t i = 0; i < paths.n; ++i) objects[i]->setWorldTransform(bodies.at_end(i));
    world.performDiscreteCollisionDetection();
    for (int m = 0; m < dispatcher.getNumManifolds(); ++m) {
      btPersistentManifold* manifold = dispatcher.getManifoldByIndexInternal(m);
      for (int c = 0; c < manifold->getNumContacts(); ++c)
        if (manifold->getContactPoint(c).getDistance() <= 0) {
          overlaps.add(uint32_t(manifold->getBody0()->getUserIndex()), uint32_t(manifold->getBody1()->getUserIndex()));
          break;
        }
    }
    overlaps.end_frame(report, paths.frame());
    report.end_frame();
  }
}

// Runs the narrow phase on each pair of leaves whose swept boxes overlap.
template <class Bodies>
struct SweptPairs final : btDbvt::ICollide {
  SweptPairs(Bodies& bodies, Report& report) : bodies(bodies), report(report) {}

  void Process(const btDbvtNode* a, const btDbvtNode* b) override {
    uint64_t i = uint64_t(a->dataAsInt), j = uint64_t(b->dataAsInt);
    if (bodies.new_contact(i, j)) report.contact(bodies.paths.frame(), uint32_t(i), uint32_t(j));
  }

  Bodies& bodies;
  Report& report;
};

// Bullet's dynamic tree used directly: its broadphase wrapper would add a pair cache (hashing
// every pair, removing stale ones a few per frame) that a pipeline visiting each pair once per
// frame does not need. Each frame every leaf is reinserted at its new swept box, which keeps the
// tree tight however far the bodies travel, and the tree is collided with itself.
template <class Bodies>
static void continuous(Bodies& bodies, Report& report) {
  auto& paths = bodies.paths;
  btDbvt tree;
  std::vector<btDbvtNode*> leaves(paths.n);
  SweptPairs<Bodies> pairs(bodies, report);
  for (bool first = true; paths.next_frame(); first = false) {
    report.begin_frame();
    for (uint64_t i = 0; i < paths.n; ++i) {
      double lo[3], hi[3];
      paths.swept_box(i, lo, hi);
      btDbvtVolume volume = btDbvtVolume::FromMM(vec(lo), vec(hi));
      if (first) {
        leaves[i] = tree.insert(volume, nullptr);
        leaves[i]->dataAsInt = int(i);
      } else {
        tree.update(leaves[i], volume);
      }
    }
    tree.collideTTpersistentStack(tree.m_root, tree.m_root, pairs);
    report.end_frame();
  }
}

template <class Bodies>
static bool run(const std::string& pipeline, Bodies& bodies, Report& report) {
  auto& paths = bodies.paths;
  if (pipeline == "bullet-dbvt") {
    btDbvtBroadphase broadphase;
    discrete(&broadphase, bodies, report);
  } else if (pipeline == "bullet-sap") {
    bt32BitAxisSweep3 broadphase(vec(paths.box_min) - btVector3(1, 1, 1), vec(paths.box_max) + btVector3(1, 1, 1),
                                 unsigned(paths.n + 1), nullptr, true);
    discrete(&broadphase, bodies, report);
  } else if (pipeline == "bullet-ccd") {
    continuous(bodies, report);
  } else {
    return false;
  }
  return true;
}

int main(int argc, char** argv) {
  return peer_main(
      argc, argv,
      [](const std::string& pipeline, Trajectory& paths, Report& report) {
        SphereBodies bodies(paths);
        return run(pipeline, bodies, report);
      },
      [](const std::string& pipeline, ShapeTrajectory& paths, Report& report) {
        ShapeBodies bodies(paths);
        return run(pipeline, bodies, report);
      });
}
