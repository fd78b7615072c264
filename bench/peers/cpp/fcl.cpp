// FCL 0.7 pipelines of vadop's peer benchmark, each as an FCL user would assemble them:
//  fcl-dtree        discrete: DynamicAABBTreeCollisionManager, each object's leaf reinserted
//                   every frame, fcl::collide on each candidate pair at frame instants;
//  fcl-dtree-refit  the same, the tree refitted in place every frame (FCL's update());
//  fcl-sap          discrete: the same with SaPCollisionManager;
//  fcl-ccd          continuous: a DynamicAABBTreeCollisionManager over each body's swept box
//                   (leaves reinserted every frame), then fcl::continuousCollide (conservative
//                   advancement, translation motion) on each candidate pair for the time of
//                   contact. FCL's default continuous solver samples 10 instants, which is no
//                   continuous test; conservative advancement is its exact one for primitive shapes;
//  fcl-ccd-refit    the same, the tree refitted in place every frame.
#include <fcl/fcl.h>
#include <memory>
#include "trajectory.h"

// A collision object whose box the benchmark sets directly: FCL's managers read getAABB(), and a
// swept box is not the box of the shape at any one pose.
class SweptObject : public fcl::CollisionObjectd {
 public:
  SweptObject(const std::shared_ptr<fcl::CollisionGeometryd>& geometry, uint64_t index) : fcl::CollisionObjectd(geometry) {
    setUserData(reinterpret_cast<void*>(index));
  }
  void set_box(const double lo[3], const double hi[3]) {
    aabb.min_ = fcl::Vector3d(lo[0], lo[1], lo[2]);
    aabb.max_ = fcl::Vector3d(hi[0], hi[1], hi[2]);
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

static void discrete(fcl::BroadPhaseCollisionManagerd& manager, Update how, Trajectory& trajectory, Report& report) {
  auto sphere = std::make_shared<fcl::Sphered>(trajectory.radius);
  std::vector<std::unique_ptr<fcl::CollisionObjectd>> objects(trajectory.n);
  std::vector<fcl::CollisionObjectd*> registered(trajectory.n);
  // Objects are registered at their first frame's start: all at the origin, every pair would
  // overlap once (FCL's SaP then spends minutes removing them from its pair list).
  bool loaded = trajectory.next_frame();
  for (uint64_t i = 0; i < trajectory.n; ++i) {
    objects[i].reset(new fcl::CollisionObjectd(sphere));
    objects[i]->setUserData(reinterpret_cast<void*>(i));
    const double* p = trajectory.start(i);
    objects[i]->setTranslation(fcl::Vector3d(p[0], p[1], p[2]));
    objects[i]->computeAABB();
    registered[i] = objects[i].get();
  }
  manager.registerObjects(registered);
  manager.setup();
  NewOverlaps overlaps;
  DiscreteData data{&overlaps, fcl::CollisionRequestd(), fcl::CollisionResultd()};
  for (; loaded; loaded = trajectory.next_frame()) {
    report.begin_frame();
    for (uint64_t i = 0; i < trajectory.n; ++i) {
      const double* p = trajectory.end(i);
      objects[i]->setTranslation(fcl::Vector3d(p[0], p[1], p[2]));
      objects[i]->computeAABB();
    }
    update(manager, registered, how);
    manager.collide(&data, discrete_pair);
    overlaps.end_frame(report, trajectory.frame());
    report.end_frame();
  }
}

struct ContinuousData {
  Trajectory* trajectory;
  Report* report;
  fcl::Sphered* sphere;
  fcl::ContinuousCollisionRequestd request;
};

static bool continuous_pair(fcl::CollisionObjectd* a, fcl::CollisionObjectd* b, void* data) {
  auto* d = static_cast<ContinuousData*>(data);
  auto cast = [&](const double a0[3], const double a1[3], const double b0[3], const double b1[3], double& fraction) {
    fcl::Transform3d from_a = fcl::Transform3d::Identity(), to_a = fcl::Transform3d::Identity();
    fcl::Transform3d from_b = fcl::Transform3d::Identity(), to_b = fcl::Transform3d::Identity();
    from_a.translation() = fcl::Vector3d(a0[0], a0[1], a0[2]);
    to_a.translation() = fcl::Vector3d(a1[0], a1[1], a1[2]);
    from_b.translation() = fcl::Vector3d(b0[0], b0[1], b0[2]);
    to_b.translation() = fcl::Vector3d(b1[0], b1[1], b1[2]);
    // The motions live on the stack: the overload taking transforms allocates both on the heap.
    fcl::TranslationMotiond motion_a(from_a, to_a), motion_b(from_b, to_b);
    fcl::ContinuousCollisionResultd result;
    fcl::continuousCollide(d->sphere, &motion_a, d->sphere, &motion_b, d->request, result);
    fraction = result.time_of_contact;
    return result.is_collide;
  };
  uint32_t i = index_of(a), j = index_of(b);
  if (d->trajectory->new_contact(i, j, cast)) d->report->contact(d->trajectory->frame(), i, j);
  return false;
}

static void continuous(Update how, Trajectory& trajectory, Report& report) {
  fcl::Sphered sphere(trajectory.radius);
  auto shared = std::make_shared<fcl::Sphered>(trajectory.radius);
  std::vector<std::unique_ptr<SweptObject>> objects(trajectory.n);
  std::vector<fcl::CollisionObjectd*> registered(trajectory.n);
  trajectory.next_frame();
  for (uint64_t i = 0; i < trajectory.n; ++i) {
    objects[i].reset(new SweptObject(shared, i));
    double lo[3], hi[3];
    trajectory.swept_box(i, lo, hi);
    objects[i]->set_box(lo, hi);
    registered[i] = objects[i].get();
  }
  fcl::DynamicAABBTreeCollisionManagerd manager;
  manager.registerObjects(registered);
  manager.setup();
  ContinuousData data{&trajectory, &report, &sphere, fcl::ContinuousCollisionRequestd()};
  data.request.ccd_solver_type = fcl::CCDC_CONSERVATIVE_ADVANCEMENT;
  data.request.ccd_motion_type = fcl::CCDM_TRANS;
  bool loaded = true;
  while (loaded) {
    report.begin_frame();
    for (uint64_t i = 0; i < trajectory.n; ++i) {
      double lo[3], hi[3];
      trajectory.swept_box(i, lo, hi);
      objects[i]->set_box(lo, hi);
    }
    update(manager, registered, how);
    manager.collide(&data, continuous_pair);
    report.end_frame();
    loaded = trajectory.next_frame();
  }
}

int main(int argc, char** argv) {
  return peer_main(argc, argv, [](const std::string& pipeline, Trajectory& trajectory, Report& report) {
    if (pipeline == "fcl-dtree" || pipeline == "fcl-dtree-refit") {
      fcl::DynamicAABBTreeCollisionManagerd manager;
      discrete(manager, pipeline == "fcl-dtree" ? Update::Each : Update::All, trajectory, report);
    } else if (pipeline == "fcl-sap") {
      fcl::SaPCollisionManagerd manager;
      discrete(manager, Update::All, trajectory, report);
    } else if (pipeline == "fcl-ccd" || pipeline == "fcl-ccd-refit") {
      continuous(pipeline == "fcl-ccd" ? Update::Each : Update::All, trajectory, report);
    } else {
      return false;
    }
    return true;
  });
}
