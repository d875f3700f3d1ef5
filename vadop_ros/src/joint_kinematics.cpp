#include "vadop_ros/joint_kinematics.h"

#include "vadop_ros/urdf_shapes.h"

#include <kdl/frames.hpp>
#include <kdl/jntarray.hpp>
#include <kdl/tree.hpp>
#include <kdl/treefksolverpos_recursive.hpp>
#include <kdl_parser/kdl_parser.hpp>
#include <urdf_parser/urdf_parser.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace vadop_ros {

struct JointKinematics::Impl {
  KDL::Tree tree;
  std::unique_ptr<KDL::TreeFkSolverPos_recursive> fk;
  std::vector<unsigned int> kdl_index;  // joints_[j] -> its q_nr in the tree
  std::string root;
};

JointKinematics::JointKinematics(const std::string& urdf_xml) : impl_(std::make_unique<Impl>()) {
  urdf::ModelInterfaceSharedPtr model;
  try {
    model = urdf::parseURDF(urdf_xml);
  } catch (const std::exception& e) {
    throw UrdfError(std::string("URDF does not parse: ") + e.what());
  }
  if (!model) throw UrdfError("URDF does not parse");
  if (!kdl_parser::treeFromUrdfModel(*model, impl_->tree)) throw UrdfError("kdl_parser cannot build the kinematic tree");
  impl_->fk = std::make_unique<KDL::TreeFkSolverPos_recursive>(impl_->tree);
  impl_->root = impl_->tree.getRootSegment()->first;
  for (const auto& [name, element] : impl_->tree.getSegments()) {
    const KDL::Joint& joint = GetTreeElementSegment(element).getJoint();
    if (joint.getType() == KDL::Joint::None) continue;
    const int j = static_cast<int>(joints_.size());
    joints_.push_back(joint.getName());
    impl_->kdl_index.push_back(GetTreeElementQNr(element));
    index_[joint.getName()] = j;
    double lo = -std::numeric_limits<double>::infinity(), hi = std::numeric_limits<double>::infinity();
    const urdf::JointConstSharedPtr uj = model->getJoint(joint.getName());
    if (uj && uj->limits && (uj->type == urdf::Joint::REVOLUTE || uj->type == urdf::Joint::PRISMATIC) &&
        uj->limits->lower < uj->limits->upper) {
      lo = uj->limits->lower;
      hi = uj->limits->upper;
    }
    lower_.push_back(lo);
    upper_.push_back(hi);
  }
}

JointKinematics::~JointKinematics() = default;

int JointKinematics::jointIndex(const std::string& name) const {
  const auto it = index_.find(name);
  return it == index_.end() ? -1 : it->second;
}

double JointKinematics::clamp(size_t j, double q) const { return std::min(std::max(q, lower_[j]), upper_[j]); }

bool JointKinematics::linkPose(const std::vector<double>& q, const std::string& link, Eigen::Isometry3d& pose) const {
  if (link == impl_->root) {
    pose = Eigen::Isometry3d::Identity();
    return true;
  }
  KDL::JntArray in(impl_->tree.getNrOfJoints());
  for (size_t j = 0; j < joints_.size() && j < q.size(); ++j) in(impl_->kdl_index[j]) = clamp(j, q[j]);
  KDL::Frame f;
  if (impl_->fk->JntToCart(in, f, link) < 0) return false;
  pose = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    pose.translation()[r] = f.p(r);
    for (int c = 0; c < 3; ++c) pose.linear()(r, c) = f.M(r, c);
  }
  return true;
}

}  // namespace vadop_ros
