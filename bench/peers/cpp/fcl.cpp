// FCL 0.7 pipelines of vadop's peer benchmark, each as an FCL user would assemble them, on
// either scene:
//  fcl-dtree        discrete: DynamicAABBTreeCollisionManager, each object's leaf reinserted
//                   every frame, fcl::collide on each candidate pair at frame instants;
//  fcl-dtree-refit  the same, the tree refitted in place every frame (FCL's update());
//  fcl-sap          discrete: the same with SaPCollisionManager;
//  fcl-ccd          continuous: a DynamicAABBTreeCollisionManager over each body's swept box
//                   (leaves reinserted every frame), then fcl::continuousCollide with
//                   conservative advancement on each candidate pair for the time of contact:
//                   TranslationMotion for the spheres, InterpMotion (a constant linear and
//                   angular velocity about the centre of mass) for the spinning shapes. FCL's
//                   default continuous solver samples 10 instants, which is no continuous test;
//                   conservative advancement is its exact one for primitive shapes;
//  fcl-ccd-refit    the same, the tree refitted in place every frame.
#include <fcl/fcl.h>
#include <memory>
#include "trajectory.h"

static fcl::Vector3d vec(const double p[3]) { return fcl::Vector3d(p[0], p[1], p[2]); }

static fcl::Transform3d at(const double p[3]) {
  fcl::Transform3d transform = fcl::Transform3d::Identity();
  transform.translation() = vec(p);
  return transform;
}

// The sphere scene's bodies as FCL sees them: one sphere, placed by its centre.
struct SphereBodies {
  explicit SphereBodies(Trajectory& paths) : paths(paths), sphere(std::make_shared<fcl::Sphered>(paths.radius)) {}

  const std::shared_ptr<fcl::CollisionGeometryd>& geometry(uint64_t) const { return sphere; }
  fcl::Transform3d at_start(uint64_t i) const { return at(paths.start(i)); }
  fcl::Transform3d at_end(uint64_t i) const { return at(paths.end(i)); }

  // Conservative advancement under translation over each piece of the frame in which both move
  // in a straight line.
  bool new_contact(uint64_t i, uint64_t j, const fcl::ContinuousCollisionRequestd& request) const {
    auto cast = [&](const double a0[3], const double a1[3], const double b0[3], const double b1[3], double& fraction) {
      // The motions live on the stack: the overload taking transforms allocates both on the heap.
      fcl::TranslationMotiond motion_a(at(a0), at(a1)), motion_b(at(b0), at(b1));
      fcl::ContinuousCollisionResultd result;
      fcl::continuousCollide(sphere.get(), &motion_a, sphere.get(), &motion_b, request, result);
      fraction = result.time_of_contact;
      return result.is_collide;
    };
    return paths.new_contact(i, j, cast);
  }

  Trajectory& paths;
  std::shared_ptr<fcl::CollisionGeometryd> sphere;
};

// FCL's capsules, cylinders and cones lie along z, the scene's along y: this turn takes FCL's z
// to the shape's y (a quarter turn about x).
static fcl::Matrix3d z_to_y() {
  fcl::Matrix3d turn;
  turn << 1, 0, 0, 0, 0, 1, 0, -1, 0;
  return turn;
}

// A scene shape as an FCL shape, and the turn from FCL's frame of it to the scene's.
static std::shared_ptr<fcl::CollisionGeometryd> fcl_shape(const ShapeSpec& spec, fcl::Matrix3d& turn) {
  const double* size = spec.size;
  turn = fcl::Matrix3d::Identity();
  switch (spec.kind) {
    case Kind::Sphere:
      return std::make_shared<fcl::Sphered>(size[0]);
    case Kind::Cuboid:
      return std::make_shared<fcl::Boxd>(2 * size[0], 2 * size[1], 2 * size[2]);
    case Kind::Capsule:
      turn = z_to_y();
      return std::make_shared<fcl::Capsuled>(size[1], 2 * size[0]);
    case Kind::Cylinder:
      turn = z_to_y();
      return std::make_shared<fcl::Cylinderd>(size[1], 2 * size[0]);
    case Kind::Cone:
      turn = z_to_y();
      return std::make_shared<fcl::Coned>(size[1], 2 * size[0]);
    case Kind::ConvexHull: {
      auto vertices = std::make_shared<std::vector<fcl::Vector3d>>();
      for (size_t k = 0; k < spec.vertices.size(); k += 3) vertices->push_back(vec(&spec.vertices[k]));
      // FCL's face encoding: each face's vertex count, then its vertices.
      auto faces = std::make_shared<std::vector<int>>();
      for (size_t k = 0; k < spec.triangles.size(); k += 3)
        faces->insert(faces->end(), {3, int(spec.triangles[k]), int(spec.triangles[k + 1]), int(spec.triangles[k + 2])});
      return std::make_shared<fcl::Convexd>(vertices, int(spec.triangles.size() / 3), faces);
    }
  }
  throw std::runtime_error("unknown shape kind");
}

// The mixed-shape scene's bodies as FCL sees them: each shape in FCL's own frame of it, turning
// about its centre of mass (InterpMotion's reference point).
struct ShapeBodies {
  explicit ShapeBodies(ShapeTrajectory& paths) : paths(paths) {
    for (const ShapeSpec& spec : paths.shapes) {
      fcl::Matrix3d turn;
      shapes.push_back(fcl_shape(spec, turn));
      turns.push_back(turn);
      centres.push_back(turn.transpose() * vec(spec.centre));
    }
  }

  const std::shared_ptr<fcl::CollisionGeometryd>& geometry(uint64_t i) const { return shapes[paths.shape_of[i]]; }
  fcl::Transform3d at_start(uint64_t i) const { return placed(i, paths.start(i)); }
  fcl::Transform3d at_end(uint64_t i) const { return placed(i, paths.end(i)); }

  // Conservative advancement under InterpMotion: from the start pose to the end pose at a
  // constant velocity of the centre of mass and a constant angular velocity about it. (FCL
  // 0.7's InterpMotion constructor from two transforms and a reference point never computes the
  // velocities, so the one taking rotations and translations is used.)
  bool new_contact(uint64_t i, uint64_t j, const fcl::ContinuousCollisionRequestd& request) const {
    fcl::InterpMotion<double> motion_i = motion(i), motion_j = motion(j);
    fcl::ContinuousCollisionResultd result;
    fcl::continuousCollide(geometry(i).get(), &motion_i, geometry(j).get(), &motion_j, request, result);
    return result.is_collide && result.time_of_contact > 0;
  }

  ShapeTrajectory& paths;
  std::vector<std::shared_ptr<fcl::CollisionGeometryd>> shapes;
  std::vector<fcl::Matrix3d> turns;
  std::vector<fcl::Vector3d> centres;

 private:
  fcl::Transform3d placed(uint64_t i, const State& state) const {
    const double* q = state.orientation;
    fcl::Transform3d transform = fcl::Transform3d::Identity();
    transform.linear() = fcl::Quaterniond(q[3], q[0], q[1], q[2]).toRotationMatrix() * turns[paths.shape_of[i]];
    transform.translation() = vec(state.position);
    return transform;
  }
  fcl::InterpMotion<double> motion(uint64_t i) const {
    fcl::Transform3d from = at_start(i), to = at_end(i);
    return fcl::InterpMotion<double>(from.linear(), from.translation(), to.linear(), to.translation(), centres[paths.shape_of[i]]);
  }
};

// A collision object whose box the benchmark sets directly: FCL's managers read getAABB(), and a
// swept box is not the box of the shape at any one pose.
class SweptObject : public fcl::CollisionObjectd {
 public:
  SweptObject(const std::shared_ptr<fcl::CollisionGeometryd>& geometry, uint64_t index) : fcl::CollisionObjectd(geometry) {
    setUserData(reinterpret_cast<void*>(index));
  }
  void set_box(const double lo[3], const double hi[3]) {
    aabb.min_ = vec(lo);
    aabb.max_ = vec(hi);
  }
};

// How a manager learns that its objects moved. All: update(), where a dynamic tree refits its
// nodes in place (plus a few rebalancing passes), cheap while bodies move little, but the tree's
// shape stops fitting once they have travelled far (SaP re-sorts its endpoints). Each:
// update(objects), where a dynamic tree reinserts every leaf, which keeps it tight at any speed
// for a higher cost per leaf.
enum class Update { All, Each };

static void update(fcl::BroadPhaseCollisionManagerd& manager, const std::vector<fcl::CollisionObjectd*>& objects, Update how) {
  if (how == Update::Each)
    manager.update(objects);
  else
    manager.update();
}

static uint32_t index_of(fcl::CollisionObjectd* object) { return uint32_t(reinterpret_cast<uint64_t>(object->getUserData())); }

struct DiscreteData {
  NewOverlaps* overlaps;
  fcl::CollisionRequestd request;
  fcl::CollisionResultd result;  // reused: a touching pair adds a contact to its vector
};

static bool discrete_pair(fcl::CollisionObjectd* a, fcl::CollisionObjectd* b, void* data) {
  auto* d = static_cast<DiscreteData*>(data);
  d->result.clear();
  if (fcl::collide(a, b, d->request, d->result) > 0) d->overlaps->add(index_of(a), index_of(b));
  return false;  // keep going: every pair is wanted
}

template <class Bodies>
static void discrete(fcl::BroadPhaseCollisionManagerd& manager, Update how, Bodies& bodies, Report& report) {
  auto& paths = bodies.paths;
  std::vector<std::unique_ptr<fcl::CollisionObjectd>> objects(paths.n);
  std::vector<fcl::CollisionObjectd*> registered(paths.n);
  // Objects are registered at their first frame's start: all at the origin, every pair would
  // overlap once (FCL's SaP then spends minutes removing them from its pair list).
  bool loaded = paths.next_frame();
  for (uint64_t i = 0; i < paths.n; ++i) {
    objects[i].reset(new fcl::CollisionObjectd(bodies.geometry(i)));
    objects[i]->setUserData(reinterpret_cast<void*>(i));
    objects[i]->setTransform(bodies.at_start(i));
    objects[i]->computeAABB();
    registered[i] = objects[i].get();
  }
  manager.registerObjects(registered);
  manager.setup();
  NewOverlaps overlaps;
  DiscreteData data{&overlaps, fcl::CollisionRequestd(), fcl::CollisionResultd()};
  for (; loaded; loaded = paths.next_frame()) {
    report.begin_frame();
    for (uint64_t i = 0; i < paths.n; ++i) {
      objects[i]->setTransform(bodies.at_end(i));
      objects[i]->computeAABB();
    }
    update(manager, registered, how);
    manager.collide(&data, discrete_pair);
    overlaps.end_frame(report, paths.frame());
    report.end_frame();
  }
}

template <class Bodies>
struct ContinuousData {
  Bodies* bodies;
  Report* report;
  fcl::ContinuousCollisionRequestd request;
};

template <class Bodies>
static bool continuous_pair(fcl::CollisionObjectd* a, fcl::CollisionObjectd* b, void* data) {
  auto* d = static_cast<ContinuousData<Bodies>*>(data);
  uint32_t i = index_of(a), j = index_of(b);
  if (d->bodies->new_contact(i, j, d->request)) d->report->contact(d->bodies->paths.frame(), i, j);
  return false;
}

template <class Bodies>
static void continuous(Update how, Bodies& bodies, Report& report) {
  auto& paths = bodies.paths;
  std::vector<std::unique_ptr<SweptObject>> objects(paths.n);
  std::vector<fcl::CollisionObjectd*> registered(paths.n);
  paths.next_frame();
  for (uint64_t i = 0; i < paths.n; ++i) {
    objects[i].reset(new SweptObject(bodies.geometry(i), i));
    double lo[3], hi[3];
    paths.swept_box(i, lo, hi);
    objects[i]->set_box(lo, hi);
    registered[i] = objects[i].get();
  }
  fcl::DynamicAABBTreeCollisionManagerd manager;
  manager.registerObjects(registered);
  manager.setup();
  ContinuousData<Bodies> data{&bodies, &report, fcl::ContinuousCollisionRequestd()};
  data.request.ccd_solver_type = fcl::CCDC_CONSERVATIVE_ADVANCEMENT;
  bool loaded = true;
  while (loaded) {
    report.begin_frame();
    for (uint64_t i = 0; i < paths.n; ++i) {
      double lo[3], hi[3];
      paths.swept_box(i, lo, hi);
      objects[i]->set_box(lo, hi);
    }
    update(manager, registered, how);
    manager.collide(&data, continuous_pair<Bodies>);
    report.end_frame();
    loaded = paths.next_frame();
  }
}

template <class Bodies>
static bool run(const std::string& pipeline, Bodies& bodies, Report& report) {
  if (pipeline == "fcl-dtree" || pipeline == "fcl-dtree-refit") {
    fcl::DynamicAABBTreeCollisionManagerd manager;
    discrete(manager, pipeline == "fcl-dtree" ? Update::Each : Update::All, bodies, report);
  } else if (pipeline == "fcl-sap") {
    fcl::SaPCollisionManagerd manager;
    discrete(manager, Update::All, bodies, report);
  } else if (pipeline == "fcl-ccd" || pipeline == "fcl-ccd-refit") {
    continuous(pipeline == "fcl-ccd" ? Update::Each : Update::All, bodies, report);
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
