// Tracked objects (~tracks), the first body-set source (source.h's BodiesSource; its code in
// src/sources/tracked_objects_source.cpp): the people, carts and vehicles a tracker reports, one
// vadop/TrackedObjectArray topic per source, with ids that appear, vanish and come back. Each
// object is a moving body "<prefix>/<id>" of one collision element (its primitive, or the
// source's default_shape) that moves with its reported twist from the array's stamp; an object
// absent from its source's arrays for the source's timeout leaves. Objects live in slots that
// are reused, so an object joining or leaving costs one world add or remove, never a rebuild.
// It does not associate detections (ids are the tracker's), smooth or filter velocities, and
// does not add the motion of a moving header frame (arrays belong in a world-fixed frame).
//
// Bad input never throws and never affects the other objects: an array with a stamp beyond
// max_stamp_skew, older than the source's last one, an empty header.frame_id or one tf cannot
// resolve at its stamp is dropped; an object with an empty id, NaN/Inf or out-of-range values,
// a zero quaternion, an unsupported primitive (CONE, PRISM, ...), a dimension that is not > 0,
// or the wrong number of dimensions is dropped and the rest of the array kept; an id twice in
// one array: the last one is kept. Each is counted and warned about (throttled per source),
// naming the source and the object's id and field.
#pragma once

#include "vadop_ros/body_registry.h"  // TransformSource, InputResult
#include "vadop_ros/params.h"
#include "vadop_ros/source.h"

#include <vadop/TrackedObjectArray.h>
#include <vadop/shapes.h>

#include <Eigen/Geometry>
#include <ros/time.h>

#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

namespace vadop_ros {

// A tracked object's slot: its latest accepted state (name "<prefix>/<id>", no link; stamp: the
// array's, its receipt when zero).
using TrackedObject = SourcedBody;

struct TrackSourceStatus {
  size_t objects = 0;  // alive now
  uint64_t arrays_accepted = 0, arrays_dropped = 0, arrays_out_of_order = 0;
  uint64_t objects_dropped = 0, objects_expired = 0;
  std::string last_problem;  // the latest dropped array or object, why
  ros::Time last_problem_receipt;
  double last_warn = -1e300;  // wall seconds of the last warning (throttle)
};

class Tracks : public BodiesSource {
 public:
  Tracks(std::vector<TrackParams> params, std::string fixed_frame, double max_stamp_skew);

  const char* kind() const override { return "tracks"; }
  bool configured() const override { return !params_.empty(); }
  // One subscription per source; each array runs onArray under the lock, stamped with the
  // node's clock at its receipt.
  std::vector<ros::Subscriber> subscribe(const Wiring& w) override;
  // The "tracks" entry (monitor_diagnostics.h lists its keys).
  void report(diagnostic_updater::DiagnosticStatusWrapper& stat, const ros::Time& now) const override;

  size_t sources() const { return params_.size(); }
  const TrackParams& params(size_t source) const { return params_.at(source); }
  const TrackSourceStatus& status(size_t source) const { return status_.at(source); }

  // One array of source `source`, received at `receipt` (the node's clock).
  InputResult onArray(size_t source, const vadop::TrackedObjectArray& msg, const ros::Time& receipt,
                      TransformSource& tf);
  // Objects not seen for their source's timeout at `now` leave; their slots are appended to
  // `left` (free for reuse from now on).
  void expire(const ros::Time& now, std::vector<size_t>& left) override;
  // An object the world cannot take (its motion out of range): it leaves, counted as dropped.
  void drop(size_t slot, const std::string& why, const ros::Time& now) override;
  // Every object leaves (time jumped back); their slots are appended to `left`.
  void clear(std::vector<size_t>& left) override;

  // Slots: alive or free; a slot keeps its index while its object lives.
  const std::vector<TrackedObject>& slots() const { return bodies_; }
  size_t alive() const { return by_name_.size(); }
  void setMaxStampSkew(double seconds) { max_stamp_skew_ = seconds; }

 private:
  // The array's header: its stamp (skew, order) and frame (`to_fixed`: into the fixed frame);
  // counts it accepted, dropped (warned) or out of order.
  InputResult checkArray(size_t source, const vadop::TrackedObjectArray& msg, const ros::Time& receipt,
                         TransformSource& tf, ros::Time& stamp, Eigen::Isometry3d& to_fixed);
  // The pose of objects[index] in the fixed frame; false and `why` (naming the field) when a
  // value is invalid or out of range.
  bool objectPose(const vadop::TrackedObject& o, size_t index, const Eigen::Isometry3d& to_fixed,
                  Eigen::Isometry3d& pose, std::string& why) const;
  // The slot of the object `name` of `source`: its own, else a free one (it joins).
  size_t slotFor(size_t source, const std::string& name);
  void problem(size_t source, const std::string& why, const ros::Time& receipt);
  void release(size_t slot);
  // The object's shape from its primitive (type 0: the source's default); false and `why` when bad.
  bool shapeOf(size_t source, const shape_msgs::SolidPrimitive& p, size_t index, vadop::Shape& out,
               std::string& why) const;

  std::vector<TrackParams> params_;
  std::string fixed_frame_;
  double max_stamp_skew_;
  std::vector<TrackSourceStatus> status_;
  std::vector<ros::Time> last_stamp_;  // per source: of the last accepted array
  // Per slot (beside bodies_): the source its object came from, the receipt of the last array
  // that had it.
  std::vector<size_t> slot_source_;
  std::vector<ros::Time> last_seen_;
  std::vector<size_t> free_;
  std::unordered_map<std::string, size_t> by_name_;
};

}  // namespace vadop_ros
