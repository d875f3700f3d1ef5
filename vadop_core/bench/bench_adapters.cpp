#include "bench_adapters.h"

#include "bench_world.h"

#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/narrowphase/collision_object.h>

#include <btBulletCollisionCommon.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <vector>

namespace vadop_bench {

void TimedBroadPhase::computeBoxes(double ta, double tb) {
  const auto& b = bodies();
  boxes_.resize(b.size());
  for (vadop::BodyId id = 0; id < b.size(); ++id) {
    if (b[id].alive) boxes_[id] = sweptBox(b[id].motion, b[id].shape->bounding_radius, ta, tb);
  }
}

namespace {

using Clock = std::chrono::steady_clock;
double seconds(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); }

// ---------------------------------------------------------------------------------------------
// FCL

// A collision object whose world AABB we set ourselves (the swept box), instead of FCL's
// computeAABB() of the geometry at one pose. The manager only reads getAABB().
class BoxObject : public fcl::CollisionObjectd {
 public:
  explicit BoxObject(const std::shared_ptr<fcl::CollisionGeometryd>& g) : fcl::CollisionObjectd(g) {}
  void setBox(const Box& b) {
    aabb.min_ = b.lo;
    aabb.max_ = b.hi;
  }
};

bool fclPairCallback(fcl::CollisionObjectd* o1, fcl::CollisionObjectd* o2, void* data) {
  auto* out = static_cast<std::vector<vadop::Pair>*>(data);
  const auto a = static_cast<vadop::BodyId>(reinterpret_cast<uintptr_t>(o1->getUserData()));
  const auto b = static_cast<vadop::BodyId>(reinterpret_cast<uintptr_t>(o2->getUserData()));
  out->push_back(vadop::makePair(a, b));
  return false;  // continue
}

// Queries: the other object of each overlap with the query object.
struct FclQuery {
  const fcl::CollisionObjectd* query;
  std::vector<vadop::BodyId>* out;
};
bool fclQueryCallback(fcl::CollisionObjectd* o1, fcl::CollisionObjectd* o2, void* data) {
  auto* q = static_cast<FclQuery*>(data);
  const fcl::CollisionObjectd* other = o1 == q->query ? o2 : o1;
  q->out->push_back(static_cast<vadop::BodyId>(reinterpret_cast<uintptr_t>(other->getUserData())));
  return false;  // continue
}

class FclBroadPhase : public TimedBroadPhase {
 public:
  FclBroadPhase(FclMode mode, BoxKind kind)
      : mode_(mode), kind_(kind), geometry_(std::make_shared<fcl::Sphered>(1.0)), query_object_(geometry_) {}

  std::string name() const override {
    std::string s = kind_ == BoxKind::kSwept ? "fcl" : "fcl_discrete";
    return s + (mode_ == FclMode::kRefit ? "_refit" : "_rebuild");
  }
  size_t memoryBytes() const override {
    // Estimate: the objects, two tree nodes per object (leaf + internal), the manager's
    // object -> leaf hash table.
    const size_t node = sizeof(fcl::AABBd) + 4 * sizeof(void*);
    return objects_.size() * (sizeof(BoxObject) + sizeof(void*)) + alive_ * (2 * node + 4 * sizeof(void*));
  }

 protected:
  void onAdd(vadop::BodyId id) override {
    if (objects_.size() <= id) objects_.resize(id + 1);
    objects_[id] = std::make_unique<BoxObject>(geometry_);
    objects_[id]->setUserData(reinterpret_cast<void*>(static_cast<uintptr_t>(id)));
    pending_.push_back(objects_[id].get());
    ++alive_;
  }
  void onRemove(vadop::BodyId id) override {
    BoxObject* o = objects_[id].get();
    auto it = std::find(pending_.begin(), pending_.end(), o);
    if (it != pending_.end()) {
      pending_.erase(it);
    } else {
      manager_.unregisterObject(o);
    }
    objects_[id].reset();
    --alive_;
  }
  void onSetMotion(vadop::BodyId) override {}

  void computePairs(double t0, double t1, std::vector<vadop::Pair>& out) override {
    const auto c0 = Clock::now();
    const auto& b = bodies();
    computeBoxes(kind_ == BoxKind::kSwept ? t0 : t1, t1);
    update_s_ = seconds(c0, Clock::now());
    for (vadop::BodyId id = 0; id < b.size(); ++id) {
      if (b[id].alive) objects_[id]->setBox(boxes_[id]);
    }
    if (mode_ == FclMode::kRebuild) {
      manager_.clear();
      all_.clear();
      for (auto& o : objects_) {
        if (o) all_.push_back(o.get());
      }
      manager_.registerObjects(all_);
      manager_.setup();
      pending_.clear();
    } else {
      if (!pending_.empty()) {
        if (manager_.size() == 0) {
          manager_.registerObjects(pending_);
        } else {
          for (auto* o : pending_) manager_.registerObject(o);
        }
        pending_.clear();
      }
      manager_.update();  // leaves <- getAABB(), refit, incremental balance
    }
    manager_.collide(&out, fclPairCallback);
  }

  // The tree's leaves hold the frame's swept boxes: a box query against them (the pseudo-
  // dynamic mode's boxes hold only the frame pose, so it has no frame answer).
  bool queryFrame(const double* box, std::vector<vadop::BodyId>& out) override {
    if (kind_ != BoxKind::kSwept) return false;
    if (manager_.size() == 0) return true;
    query_object_.setBox(Box{Eigen::Vector3d(box[0], box[1], box[2]), Eigen::Vector3d(box[3], box[4], box[5])});
    FclQuery q{&query_object_, &out};
    manager_.collide(&query_object_, &q, fclQueryCallback);
    return true;
  }

 private:
  FclMode mode_;
  BoxKind kind_;
  std::shared_ptr<fcl::CollisionGeometryd> geometry_;
  std::vector<std::unique_ptr<BoxObject>> objects_;
  std::vector<fcl::CollisionObjectd*> pending_, all_;
  size_t alive_ = 0;
  fcl::DynamicAABBTreeCollisionManagerd manager_;
  BoxObject query_object_;
};

// ---------------------------------------------------------------------------------------------
// Bullet (btScalar is float in Debian's libbullet: round the box outwards)

btVector3 floorVec(const Eigen::Vector3d& v) {
  btVector3 out(0, 0, 0);
  for (int k = 0; k < 3; ++k) {
    float f = static_cast<float>(v[k]);
    if (static_cast<double>(f) > v[k]) f = std::nextafter(f, -INFINITY);
    out[k] = f;
  }
  return out;
}
btVector3 ceilVec(const Eigen::Vector3d& v) {
  btVector3 out(0, 0, 0);
  for (int k = 0; k < 3; ++k) {
    float f = static_cast<float>(v[k]);
    if (static_cast<double>(f) < v[k]) f = std::nextafter(f, INFINITY);
    out[k] = f;
  }
  return out;
}

class BulletBroadPhase : public TimedBroadPhase {
 public:
  BulletBroadPhase() : dispatcher_(&config_) {}
  ~BulletBroadPhase() override {
    for (auto* p : proxies_) {
      if (p) broadphase_.destroyProxy(p, &dispatcher_);
    }
  }
  std::string name() const override { return "bullet"; }
  size_t memoryBytes() const override {
    // Estimate: proxies, two tree nodes per proxy, the pair cache.
    return alive_ * (sizeof(btDbvtProxy) + 2 * sizeof(btDbvtNode)) + proxies_.capacity() * sizeof(void*) +
           boxes_.capacity() * sizeof(Box) +
           static_cast<size_t>(const_cast<btDbvtBroadphase&>(broadphase_).getOverlappingPairCache()->getNumOverlappingPairs()) *
               (sizeof(btBroadphasePair) + 2 * sizeof(int));
  }

 protected:
  void onAdd(vadop::BodyId id) override {
    if (proxies_.size() <= id) proxies_.resize(id + 1, nullptr);
    const auto& body = bodies()[id];
    const Box box = sweptBox(body.motion, body.shape->bounding_radius, body.motion.t_ref, body.motion.t_ref);
    proxies_[id] = broadphase_.createProxy(floorVec(box.lo), ceilVec(box.hi), SPHERE_SHAPE_PROXYTYPE,
                                           reinterpret_cast<void*>(static_cast<uintptr_t>(id)), 1, -1, &dispatcher_);
    ++alive_;
  }
  void onRemove(vadop::BodyId id) override {
    broadphase_.destroyProxy(proxies_[id], &dispatcher_);
    proxies_[id] = nullptr;
    --alive_;
  }
  void onSetMotion(vadop::BodyId) override {}

  void computePairs(double t0, double t1, std::vector<vadop::Pair>& out) override {
    const auto c0 = Clock::now();
    const auto& b = bodies();
    computeBoxes(t0, t1);
    update_s_ = seconds(c0, Clock::now());
    for (vadop::BodyId id = 0; id < b.size(); ++id) {
      if (b[id].alive) broadphase_.setAabb(proxies_[id], floorVec(boxes_[id].lo), ceilVec(boxes_[id].hi), &dispatcher_);
    }
    broadphase_.calculateOverlappingPairs(&dispatcher_);
    btOverlappingPairCache* cache = broadphase_.getOverlappingPairCache();
    const int np = cache->getNumOverlappingPairs();
    const btBroadphasePair* pairs = cache->getOverlappingPairArrayPtr();
    for (int i = 0; i < np; ++i) {
      const auto a = static_cast<vadop::BodyId>(reinterpret_cast<uintptr_t>(pairs[i].m_pProxy0->m_clientObject));
      const auto c = static_cast<vadop::BodyId>(reinterpret_cast<uintptr_t>(pairs[i].m_pProxy1->m_clientObject));
      if (overlaps(boxes_[a], boxes_[c])) out.push_back(vadop::makePair(a, c));  // drop stale cache pairs
    }
  }

  // The tree's leaves hold the frame's swept boxes, rounded outwards to float and fattened by
  // Bullet's margin: its answer is filtered by the boxes themselves, as the pairs are.
  bool queryFrame(const double* box, std::vector<vadop::BodyId>& out) override {
    struct Collect : btBroadphaseAabbCallback {
      std::vector<vadop::BodyId>* out = nullptr;
      const std::vector<Box>* boxes = nullptr;
      Box query;
      bool process(const btBroadphaseProxy* proxy) override {
        const auto id = static_cast<vadop::BodyId>(reinterpret_cast<uintptr_t>(proxy->m_clientObject));
        if (overlaps((*boxes)[id], query)) out->push_back(id);
        return true;
      }
    } collect;
    collect.out = &out;
    collect.boxes = &boxes_;
    collect.query = Box{Eigen::Vector3d(box[0], box[1], box[2]), Eigen::Vector3d(box[3], box[4], box[5])};
    broadphase_.aabbTest(floorVec(Eigen::Vector3d(box[0], box[1], box[2])),
                         ceilVec(Eigen::Vector3d(box[3], box[4], box[5])), collect);
    return true;
  }

 private:
  btDefaultCollisionConfiguration config_;
  btCollisionDispatcher dispatcher_;
  btDbvtBroadphase broadphase_;
  std::vector<btBroadphaseProxy*> proxies_;
  size_t alive_ = 0;
};

// FCL rebuild that drops every fifth candidate pair: the self-test of the miss detection.
class FaultyBroadPhase : public FclBroadPhase {
 public:
  FaultyBroadPhase() : FclBroadPhase(FclMode::kRebuild, BoxKind::kSwept) {}
  std::string name() const override { return "faulty"; }

 protected:
  void computePairs(double t0, double t1, std::vector<vadop::Pair>& out) override {
    FclBroadPhase::computePairs(t0, t1, out);
    size_t w = 0;
    for (size_t i = 0; i < out.size(); ++i)
      if (i % 5 != 4) out[w++] = out[i];
    out.resize(w);
  }
};

}  // namespace

std::unique_ptr<TimedBroadPhase> makeFaultyBroadPhase() { return std::make_unique<FaultyBroadPhase>(); }
std::unique_ptr<TimedBroadPhase> makeFclBroadPhase(FclMode mode, BoxKind boxes) {
  return std::make_unique<FclBroadPhase>(mode, boxes);
}
std::unique_ptr<TimedBroadPhase> makeBulletBroadPhase() { return std::make_unique<BulletBroadPhase>(); }

}  // namespace vadop_bench
