// Test helper: a TransformSource from a table of static transforms (parent -> child), with
// chaining through a common root and per-frame stamps.
#pragma once

#include "vadop_ros/body_registry.h"

#include <atomic>
#include <map>
#include <string>

namespace vadop_test {

class FakeTf : public vadop_ros::TransformSource {
 public:
  // Pose of `child` in `parent` (a tree: every frame has at most one parent).
  void set(const std::string& parent, const std::string& child, const Eigen::Isometry3d& pose,
           const ros::Time& stamp = ros::Time(1.0)) {
    parent_[child] = parent;
    pose_[child] = pose;
    stamp_[child] = stamp;
  }
  void erase(const std::string& child) {
    parent_.erase(child);
    pose_.erase(child);
  }
  std::atomic<int> lookups{0};
  // Lookups only read the tables: safe on several threads (BodyRegistry::update in parallel).
  bool concurrent_lookups = false;
  bool concurrent() const override { return concurrent_lookups; }

  bool parent(const std::string& frame, const ros::Time&, std::string& parent) override {
    const auto it = parent_.find(frame);
    if (it == parent_.end()) return false;
    parent = it->second;
    return true;
  }

  bool lookup(const std::string& target, const std::string& source, const ros::Time&, Eigen::Isometry3d& pose,
              ros::Time& stamp, std::string& error) override {
    ++lookups;
    Eigen::Isometry3d t_root, s_root;
    ros::Time st1, st2;
    std::string root_t, root_s;
    if (!toRoot(target, t_root, root_t, st1) || !toRoot(source, s_root, root_s, st2) || root_t != root_s) {
      error = "\"" + source + "\" passed to lookupTransform argument source_frame does not exist";
      return false;
    }
    pose = t_root.inverse() * s_root;
    stamp = std::max(st1, st2);
    return true;
  }

 private:
  bool toRoot(const std::string& frame, Eigen::Isometry3d& pose, std::string& root, ros::Time& stamp) const {
    pose = Eigen::Isometry3d::Identity();
    stamp = ros::Time(0.0);
    std::string f = frame;
    for (int guard = 0; guard < 100; ++guard) {
      const auto it = parent_.find(f);
      if (it == parent_.end()) {
        root = f;
        // A frame nobody mentions does not exist (unless it is a known root).
        return guard > 0 || roots_.count(f) || isParent(f);
      }
      pose = pose_.at(f) * pose;
      stamp = std::max(stamp, stamp_.at(f));
      f = it->second;
    }
    return false;
  }
  bool isParent(const std::string& f) const {
    for (const auto& kv : parent_) {
      if (kv.second == f) return true;
    }
    return false;
  }
  std::map<std::string, std::string> parent_;
  std::map<std::string, Eigen::Isometry3d> pose_;
  std::map<std::string, ros::Time> stamp_;
  std::map<std::string, int> roots_;
};

}  // namespace vadop_test
