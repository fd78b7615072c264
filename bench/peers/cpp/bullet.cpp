// Bullet 3 pipelines of vadop's peer benchmark, each as a Bullet user would assemble it:
//  bullet-dbvt  discrete: btCollisionWorld + btDbvtBroadphase, overlaps at frame instants;
//  bullet-sap   discrete: the same with bt32BitAxisSweep3 (the 16-bit btAxisSweep3 holds at most
//               16383 objects, too few for this benchmark; the algorithm is the same);
//  bullet-ccd   continuous: a btDbvt over each body's swept box (leaves reinserted every frame),
//               its self-collision (each overlapping pair once), then btGjkConvexCast (Bullet's
//               convex cast) on each pair for the time of impact.
// Debian builds Bullet in single precision, so positions are rounded to float inside Bullet.
#include <btBulletCollisionCommon.h>
#include <BulletCollision/NarrowPhaseCollision/btGjkConvexCast.h>
#include <BulletCollision/NarrowPhaseCollision/btVoronoiSimplexSolver.h>
#include <memory>
#include "trajectory.h"

static btVector3 vec(const double p[3]) { return btVector3(btScalar(p[0]), btScalar(p[1]), btScalar(p[2])); }

static void discrete(btBroadphaseInterface* broadphase, Trajectory& trajectory, Report& report) {
  btDefaultCollisionConfiguration configuration;
  btCollisionDispatcher dispatcher(&configuration);
  btCollisionWorld world(&dispatcher, broadphase, &configuration);
  btSphereShape sphere(btScalar(trajectory.radius));
  std::vector<std::unique_ptr<btCollisionObject>> objects(trajectory.n);
  // Objects enter the world at their first frame's start: all at the origin, every pair would
  // overlap once.
  bool loaded = trajectory.next_frame();
  for (uint64_t i = 0; i < trajectory.n; ++i) {
    objects[i].reset(new btCollisionObject());
    objects[i]->setCollisionShape(&sphere);
    objects[i]->setUserIndex(int(i));
    btTransform transform;
    transform.setIdentity();
    transform.setOrigin(vec(trajectory.start(i)));
    objects[i]->setWorldTransform(transform);
    world.addCollisionObject(objects[i].get());
  }
  NewOverlaps overlaps;
  for (; loaded; loaded = trajectory.next_frame()) {
    report.begin_frame();
    for (uint64_t i = 0; i < trajectory.n; ++i) {
      btTransform transform;
      transform.setIdentity();
      transform.setOrigin(vec(trajectory.end(i)));
      objects[i]->setWorldTransform(transform);
    }
    world.performDiscreteCollisionDetection();
    for (int m = 0; m < dispatcher.getNumManifolds(); ++m) {
      btPersistentManifold* manifold = dispatcher.getManifoldByIndexInternal(m);
      for (int c = 0; c < manifold->getNumContacts(); ++c)
        if (manifold->getContactPoint(c).getDistance() <= 0) {
          overlaps.add(uint32_t(manifold->getBody0()->getUserIndex()), uint32_t(manifold->getBody1()->getUserIndex()));
          break;
        }
    }
    overlaps.end_frame(report, trajectory.frame());
    report.end_frame();
  }
}

// Runs the narrow phase on each pair of leaves whose swept boxes overlap.
struct SweptPairs final : btDbvt::ICollide {
  SweptPairs(Trajectory& trajectory, Report& report, btScalar radius) : trajectory(trajectory), report(report), sphere(radius) {}

  void Process(const btDbvtNode* a, const btDbvtNode* b) override {
    auto cast = [&](const double a0[3], const double a1[3], const double b0[3], const double b1[3], double& fraction) {
      btTransform from_a, to_a, from_b, to_b;
      from_a.setIdentity(), to_a.setIdentity(), from_b.setIdentity(), to_b.setIdentity();
      from_a.setOrigin(vec(a0)), to_a.setOrigin(vec(a1)), from_b.setOrigin(vec(b0)), to_b.setOrigin(vec(b1));
      btGjkConvexCast caster(&sphere, &sphere, &simplex);
      btConvexCast::CastResult result;
      if (!caster.calcTimeOfImpact(from_a, to_a, from_b, to_b, result)) return false;
      fraction = result.m_fraction;
      return true;
    };
    uint64_t i = uint64_t(a->dataAsInt), j = uint64_t(b->dataAsInt);
    if (trajectory.new_contact(i, j, cast)) report.contact(trajectory.frame(), uint32_t(i), uint32_t(j));
  }

  Trajectory& trajectory;
  Report& report;
  btSphereShape sphere;
  btVoronoiSimplexSolver simplex;
};

// Bullet's dynamic tree used directly: its broadphase wrapper would add a pair cache (hashing
// every pair, removing stale ones a few per frame) that a pipeline visiting each pair once per
// frame does not need. Each frame every leaf is reinserted at its new swept box, which keeps the
// tree tight however far the bodies travel, and the tree is collided with itself.
static void continuous(Trajectory& trajectory, Report& report) {
  btDbvt tree;
  std::vector<btDbvtNode*> leaves(trajectory.n);
  SweptPairs pairs(trajectory, report, btScalar(trajectory.radius));
  for (bool first = true; trajectory.next_frame(); first = false) {
    report.begin_frame();
    for (uint64_t i = 0; i < trajectory.n; ++i) {
      double lo[3], hi[3];
      trajectory.swept_box(i, lo, hi);
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

int main(int argc, char** argv) {
  return peer_main(argc, argv, [](const std::string& pipeline, Trajectory& trajectory, Report& report) {
    if (pipeline == "bullet-dbvt") {
      btDbvtBroadphase broadphase;
      discrete(&broadphase, trajectory, report);
    } else if (pipeline == "bullet-sap") {
      bt32BitAxisSweep3 broadphase(vec(trajectory.box_min) - btVector3(1, 1, 1), vec(trajectory.box_max) + btVector3(1, 1, 1),
                                   unsigned(trajectory.n + 1), nullptr, true);
      discrete(&broadphase, trajectory, report);
    } else if (pipeline == "bullet-ccd") {
      continuous(trajectory, report);
    } else {
      return false;
    }
    return true;
  });
}
