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

namespace {

Eigen::Isometry3d toEigen(const KDL::Frame& f) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    pose.translation()[r] = f.p(r);
    for (int c = 0; c < 3; ++c) pose.linear()(r, c) = f.M(r, c);
  }
  return pose;
}

}  // namespace

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
  pose = toEigen(f);
  return true;
}


bool JointKinematics::chain(const std::string& from, const std::string& to, std::vector<Step>& steps) const {
  const auto& segments = impl_->tree.getSegments();
  // The segments from a link up to the root (the root's own segment excluded).
  auto upward = [&](const std::string& link, std::vector<std::string>& out) {
    auto it = segments.find(link);
    if (it == segments.end()) return false;
    while (it->first != impl_->root) {
      out.push_back(it->first);
      it = GetTreeElementParent(it->second);
    }
    return true;
  };
  std::vector<std::string> up_from, up_to;
  if (!upward(from, up_from) || !upward(to, up_to)) return false;
  // Drop the common part (from the root down).
  while (!up_from.empty() && !up_to.empty() && up_from.back() == up_to.back()) {
    up_from.pop_back();
    up_to.pop_back();
  }
  // Segment s carries its parent's frame to its own: pose(q) = pose(0) * J(q), J about the
  // joint's axis expressed in the child frame at q = 0 (KDL gives it in the parent's).
  auto step = [&](const std::string& name, double sign, Step& out) {
    const KDL::Segment& seg = GetTreeElementSegment(segments.find(name)->second);
    const KDL::Joint& joint = seg.getJoint();
    const KDL::Frame origin = seg.pose(0.0);
    out.origin = toEigen(origin);
    out.sign = sign;
    out.joint = jointIndex(joint.getName());
    if (joint.getType() == KDL::Joint::None || out.joint < 0) {
      out.kind = Step::Kind::kFixed;
      out.joint = -1;
      return;
    }
    out.kind = joint.getType() == KDL::Joint::TransAxis ? Step::Kind::kPrismatic : Step::Kind::kRevolute;
    const KDL::Vector a = origin.M.Inverse() * joint.JointAxis();
    out.axis = Eigen::Vector3d(a.x(), a.y(), a.z());
  };
  steps.clear();
  for (const std::string& name : up_from) {
    // Undo the segment: (pose(0) J(q))^-1 = J(-q) pose(0)^-1.
    Step turn;
    step(name, -1.0, turn);
    Step back;
    back.origin = turn.origin.inverse();
    if (turn.kind != Step::Kind::kFixed) {
      turn.origin = Eigen::Isometry3d::Identity();
      steps.push_back(turn);
    }
    steps.push_back(back);
  }
  for (auto it = up_to.rbegin(); it != up_to.rend(); ++it) {
    Step s;
    step(*it, 1.0, s);
    steps.push_back(s);
  }
  return true;
}

}  // namespace vadop_ros
