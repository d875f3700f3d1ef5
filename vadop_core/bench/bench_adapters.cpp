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

class FclBroadPhase : public TimedBroadPhase {
 public:
  FclBroadPhase(FclMode mode, BoxKind kind)
      : mode_(mode), kind_(kind), geometry_(std::make_shared<fcl::Sphered>(1.0)) {}

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

 private:
  FclMode mode_;
  BoxKind kind_;
  std::shared_ptr<fcl::CollisionGeometryd> geometry_;
  std::vector<std::unique_ptr<BoxObject>> objects_;
  std::vector<fcl::CollisionObjectd*> pending_, all_;
  size_t alive_ = 0;
  fcl::DynamicAABBTreeCollisionManagerd manager_;
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

 private:
  btDefaultCollisionConfiguration config_;
  btCollisionDispatcher dispatcher_;
  btDbvtBroadphase broadphase_;
  std::vector<btBroadphaseProxy*> proxies_;
  size_t alive_ = 0;
};

// ---------------------------------------------------------------------------------------------
// Uniform grid (the bench's reference for large n)

class GridBroadPhase : public TimedBroadPhase {
 public:
  std::string name() const override { return "grid"; }
  size_t memoryBytes() const override {
    return packed_.capacity() * sizeof(Box) + (cell_start_.capacity() + cell_body_.capacity() + ids_.capacity() +
                                              cell_of_.capacity()) * sizeof(uint32_t);
  }

 protected:
  void onAdd(vadop::BodyId) override {}
  void onRemove(vadop::BodyId) override {}
  void onSetMotion(vadop::BodyId) override {}

  void computePairs(double t0, double t1, std::vector<vadop::Pair>& out) override {
    const auto c0 = Clock::now();
    const auto& b = bodies();
    packed_.clear();
    ids_.clear();
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(INFINITY), hi = -lo;
    ext_.clear();
    for (vadop::BodyId id = 0; id < b.size(); ++id) {
      if (!b[id].alive) continue;
      packed_.push_back(sweptBox(b[id].motion, b[id].shape->bounding_radius, t0, t1));
      ids_.push_back(id);
      lo = lo.cwiseMin(packed_.back().lo);
      hi = hi.cwiseMax(packed_.back().hi);
      ext_.push_back((packed_.back().hi - packed_.back().lo).maxCoeff());
    }
    update_s_ = seconds(c0, Clock::now());
    const size_t n = packed_.size();
    if (n < 2) return;
    // Cells no smaller than 98% of the boxes, about one box per cell; boxes listed by their
    // lo corner. The few larger boxes ("big") are paired with the small ones by a range query
    // and with each other exhaustively.
    std::vector<double> e = ext_;
    const size_t kth = std::min(n - 1, static_cast<size_t>(0.98 * n));
    std::nth_element(e.begin(), e.begin() + kth, e.end());
    const double side = (hi - lo).maxCoeff();
    const double h = std::max(e[kth], side / std::cbrt(static_cast<double>(n)));
    const int g = std::max(1, static_cast<int>(std::ceil(side / h)) + 1);
    auto cell = [&](double x, int axis) {
      const double c = std::floor((x - lo[axis]) / h);
      return c <= 0.0 ? 0 : (c >= g - 1 ? g - 1 : static_cast<int>(c));
    };
    const size_t cells = static_cast<size_t>(g) * g * g;
    cell_start_.assign(cells + 1, 0);
    cell_of_.resize(n);
    cell_body_.resize(n);
    for (size_t i = 0; i < n; ++i) {
      const Box& bx = packed_[i];
      cell_of_[i] = static_cast<uint32_t>((static_cast<size_t>(cell(bx.lo.z(), 2)) * g + cell(bx.lo.y(), 1)) * g +
                                          cell(bx.lo.x(), 0));
      ++cell_start_[cell_of_[i] + 1];
    }
    std::partial_sum(cell_start_.begin(), cell_start_.end(), cell_start_.begin());
    {
      std::vector<uint32_t> fill(cell_start_.begin(), cell_start_.end() - 1);
      for (size_t i = 0; i < n; ++i) cell_body_[fill[cell_of_[i]]++] = static_cast<uint32_t>(i);
    }
    big_.clear();
    for (size_t i = 0; i < n; ++i) {
      if (ext_[i] > h) big_.push_back(static_cast<uint32_t>(i));
    }
    for (size_t i = 0; i < n; ++i) {
      const Box& bx = packed_[i];
      const bool i_big = ext_[i] > h;
      const int x0 = cell(bx.lo.x() - h, 0), x1 = cell(bx.hi.x(), 0);
      const int y0 = cell(bx.lo.y() - h, 1), y1 = cell(bx.hi.y(), 1);
      const int z0 = cell(bx.lo.z() - h, 2), z1 = cell(bx.hi.z(), 2);
      for (int z = z0; z <= z1; ++z)
        for (int y = y0; y <= y1; ++y) {
          const size_t row = (static_cast<size_t>(z) * g + y) * g;
          for (uint32_t k = cell_start_[row + x0]; k < cell_start_[row + x1 + 1]; ++k) {
            const uint32_t j = cell_body_[k];
            // Small-small pairs once (j > i); a big body pairs with every small one here.
            if (ext_[j] > h || (!i_big && j <= i)) continue;
            if (overlaps(bx, packed_[j])) out.push_back(vadop::makePair(ids_[i], ids_[j]));
          }
        }
    }
    for (size_t x = 0; x < big_.size(); ++x)
      for (size_t y = x + 1; y < big_.size(); ++y)
        if (overlaps(packed_[big_[x]], packed_[big_[y]])) out.push_back(vadop::makePair(ids_[big_[x]], ids_[big_[y]]));
  }

 private:
  std::vector<Box> packed_;
  std::vector<vadop::BodyId> ids_;
  std::vector<double> ext_;
  std::vector<uint32_t> cell_start_, cell_body_, cell_of_, big_;
};

class FaultyBroadPhase : public GridBroadPhase {
 public:
  std::string name() const override { return "faulty_grid"; }

 protected:
  void computePairs(double t0, double t1, std::vector<vadop::Pair>& out) override {
    GridBroadPhase::computePairs(t0, t1, out);
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
std::unique_ptr<TimedBroadPhase> makeGridBroadPhase() { return std::make_unique<GridBroadPhase>(); }

}  // namespace vadop_bench
