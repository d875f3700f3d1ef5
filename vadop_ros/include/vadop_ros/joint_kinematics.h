// Forward kinematics of a URDF robot (kdl_parser + orocos-kdl): each link's pose in the root
// link's frame at given joint positions, for bodies whose links move with their joint states
// (joint_states_topic). Movable joints are revolute, continuous and prismatic ones; positions of
// revolute and prismatic joints are clamped to their URDF limits (a joint stops there). Mimic
// joints are not followed (they stay at zero). It knows nothing of time or messages.
#pragma once

#include <Eigen/Geometry>

#include <map>
#include <memory>
#include <string>
#include <vector>

namespace vadop_ros {

class JointKinematics {
 public:
  // Throws UrdfError (urdf_shapes.h) when the description does not parse or KDL cannot build
  // its tree.
  explicit JointKinematics(const std::string& urdf_xml);
  ~JointKinematics();
  JointKinematics(const JointKinematics&) = delete;
  JointKinematics& operator=(const JointKinematics&) = delete;

  // The movable joints, in the order positions are given.
  const std::vector<std::string>& joints() const { return joints_; }
  // Index of a movable joint, or -1 (unknown or fixed).
  int jointIndex(const std::string& name) const;
  // The position of joint j clamped to its limits (revolute and prismatic).
  double clamp(size_t j, double q) const;

  double lower(size_t j) const { return lower_[j]; }  // -inf when unlimited
  double upper(size_t j) const { return upper_[j]; }  // +inf when unlimited

  // Pose of `link` in the root link's frame at joint positions q (joints().size() values,
  // clamped here). False for an unknown link.
  bool linkPose(const std::vector<double>& q, const std::string& link, Eigen::Isometry3d& pose) const;

  // One step of a serial chain: the transform origin * J(sign * q_joint), J a turn about or a
  // slide along `axis` (fixed steps: origin alone).
  struct Step {
    enum class Kind { kFixed, kRevolute, kPrismatic };
    Kind kind = Kind::kFixed;
    int joint = -1;  // index into joints(); -1 for a fixed step
    double sign = 1.0;
    Eigen::Isometry3d origin = Eigen::Isometry3d::Identity();
    Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
  };
  // The steps taking `from`'s frame to `to`'s (up the tree from `from` to the common ancestor,
  // undone joint by joint, then down to `to`): their product at q is
  // linkPose(from)^-1 * linkPose(to). False for an unknown link.
  bool chain(const std::string& from, const std::string& to, std::vector<Step>& steps) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::vector<std::string> joints_;
  std::vector<double> lower_, upper_;  // -inf / +inf when unlimited
  std::map<std::string, int> index_;
};

}  // namespace vadop_ros
