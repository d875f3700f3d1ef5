// What the robots' own sensors see (~sensors, the body-set source of kind "sensors"; its code in
// src/sources/sensors_source.cpp): each configured sensor is one body "<name>" (no link) in its
// own slot (slot i: sensor i), the obstacles of its latest accepted message as one shape, static
// (v = w = 0) until the next message replaces it. A laser scan (sensor_msgs/LaserScan, projected
// by laser_geometry) and a point cloud (sensor_msgs/PointCloud2) give points, each a ball of
// point_radius; an occupancy grid (nav_msgs/OccupancyGrid) gives its cells with a value >=
// occupied, each a box of the cell's size over the height band. Points are placed in the fixed
// frame with tf at the message's stamp, those outside [min_z, max_z] dropped, a cloud's thinned
// to one per voxel; the body's pose is their centroid (so that the shape's bounding radius is
// the points' spread, not their distance from the origin).
//
// Staleness: a sensor with no accepted message yet, or none for its timeout, is stale
// (staleInput): the gates then publish zero Twists; its points leave the world after the
// timeout (expire). A map with timeout 0 never goes stale once one arrived.
// Bad messages never throw and never touch the kept points: a stamp beyond max_stamp_skew, an
// empty or unresolvable header.frame_id, a scan's non-finite angles or range limits, a cloud
// whose x/y/z fields are missing or not FLOAT32 or whose point_step, row_step or data size do
// not fit, a grid whose data size differs from width x height or whose resolution or origin is
// invalid: the message is dropped, counted and warned about (throttled per sensor) naming the
// sensor and the field; the previous points stay until the timeout. A message older than the
// sensor's last one is ignored (out of order).
// NaN ranges (REP 117: an erroneous measurement; +Inf: nothing within range_max, -Inf: too close)
// give no point; a NaN beam is counted ("beams NaN") and warned about naming ranges[i], but the
// rest of the scan is kept: dropping every scan of a REP 117 driver that reports an erroneous
// beam would leave the sensor stale and stop every gate. A cloud's non-finite points (an
// organized cloud's "no return") and points beyond vadop::kMaxCoordinate are skipped and counted.
//
// Points within a monitored body or a tracked object, posed at the message's stamp and grown by
// filter_margin, are dropped (the sensor's own body, the one its frame hangs from in tf: by
// self_margin); a map's cells by their centres. That body is predicted from its own motion
// instead. How they are posed and culled: sensor_filter.h. Counted per sensor ("points
// filtered"); never against another sensor's points or a static obstacle.
//
// A message's points, filter and shape are built without the node's lock (a 30,000-point cloud
// takes a few ms on the 2-core machine) from a snapshot of the bodies taken under it (the
// provider's, at most one per cycle), then committed under it: the gates do not wait for them.
//
// It does not (yet): compensate a moving sensor's motion during a scan, or merge a map's cells.
#pragma once

#include "vadop_ros/body_registry.h"  // TransformSource, InputResult
#include "vadop_ros/params.h"
#include "vadop_ros/sensor_filter.h"
#include "vadop_ros/source.h"
#include "vadop_ros/voxel_filter.h"

#include <laser_geometry/laser_geometry.h>
#include <nav_msgs/OccupancyGrid.h>
#include <sensor_msgs/LaserScan.h>
#include <sensor_msgs/PointCloud2.h>

#include <vadop/shapes.h>

#include <Eigen/Geometry>
#include <ros/time.h>

#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

namespace vadop_ros {

struct SensorStatus {
  uint64_t accepted = 0, dropped = 0, out_of_order = 0, expired = 0;
  uint64_t beams_nan = 0;        // scans: NaN ranges (no point)
  uint64_t points_skipped = 0;   // clouds: non-finite points; all: points beyond kMaxCoordinate
  // Within the sensor's own body grown by self_margin / within another body by filter_margin.
  uint64_t points_filtered_self = 0, points_filtered_others = 0;
  size_t points = 0;             // kept now (a map: occupied cells)
  ros::Time last_receipt;        // of the last accepted message (zero: none yet)
  std::string last_problem;      // the latest dropped message (or NaN beam), why
  ros::Time last_problem_receipt;
  double last_warn = -1e300;     // wall seconds of the last warning (throttle)
};

// A gated body's ~padding must exceed every sensor's self_margin (see checkSelfMargins in
// sensors_source.cpp); throws ParamError naming both. Start-up and dynamic_reconfigure check it.
void checkSelfMargins(const MonitorParams& p);

class SensorsSource : public BodiesSource {
 public:
  // `threads`: the node's ~threads (0: one per hardware thread), on which a large message's
  // points are filtered and put in their tree, within its callback.
  SensorsSource(std::vector<SensorParams> params, std::string fixed_frame, double max_stamp_skew, int threads = 1);

  const char* kind() const override { return "sensors"; }
  bool configured() const override { return !params_.empty(); }
  // One subscription per sensor, of its type; each message runs its handler under the lock,
  // stamped with the node's clock at its receipt.
  std::vector<ros::Subscriber> subscribe(const Wiring& w) override;
  void report(diagnostic_updater::DiagnosticStatusWrapper& stat, const ros::Time& now) const override;
  // Sensors without an accepted message for their timeout leave (their points go); so does a
  // sensor whose last accepted message had no point.
  void expire(const ros::Time& now, std::vector<size_t>& left) override;
  void drop(size_t slot, const std::string& why, const ros::Time& now) override;
  void clear(std::vector<size_t>& left) override;
  // The first sensor, in ~sensors order, that `ignored` does not leave out and that has no
  // accepted message yet or none within its timeout at `now`; `why` names it.
  bool staleInput(const ros::Time& now, const std::function<bool(const std::string& name)>& ignored,
                  std::string& why) const override;

  // One message of sensor `sensor` (of its type), received at `receipt` (the node's clock).
  // `lock` null: the caller holds whatever guards the core. Otherwise the lock that does, as
  // the subscriptions use it: taken to read the filter's snapshot, released while the points
  // and shape are built, taken again to commit them (a caller on a thread of its own, beside
  // the cycle, as the node's sensors' thread is).
  InputResult onScan(size_t sensor, const sensor_msgs::LaserScan& msg, const ros::Time& receipt, TransformSource& tf,
                     std::mutex* lock = nullptr);
  InputResult onCloud(size_t sensor, const sensor_msgs::PointCloud2& msg, const ros::Time& receipt,
                      TransformSource& tf, std::mutex* lock = nullptr);
  InputResult onMap(size_t sensor, const nav_msgs::OccupancyGrid& msg, const ros::Time& receipt, TransformSource& tf,
                    std::mutex* lock = nullptr);

  // What the points are filtered against: called under the node's lock once per message
  // (MonitorCore's snapshot of its last cycle). None: nothing is filtered.
  using FilterProvider = std::function<std::shared_ptr<const FilterSnapshot>()>;
  void setFilterProvider(FilterProvider provider) { filter_provider_ = std::move(provider); }

  size_t sensors() const { return params_.size(); }
  const SensorParams& params(size_t sensor) const { return params_.at(sensor); }
  const SensorStatus& status(size_t sensor) const { return status_.at(sensor); }
  // The kept points (a map: the occupied cells' centres) in the fixed frame: the markers'.
  const std::vector<Eigen::Vector3d>& points(size_t sensor) const { return points_.at(sensor); }
  bool stale(size_t sensor, const ros::Time& now) const;
  void setMaxStampSkew(double seconds) { max_stamp_skew_ = seconds; }
  // The node's ~padding: each message's shape is prepared grown by it (SourcedBody::prepared),
  // in the message's callback. Any thread; a message prepared before a change is prepared again
  // by the cycle.
  void setPadding(double padding) { padding_.store(padding); }

  // A map's height band in the fixed frame: [min_z, max_z], a side not given 2 m from the
  // other, neither given [0, 2] m.
  static std::pair<double, double> mapBand(const SensorParams& p);

 private:
  // One sensor's message as prepared without the node's lock (prepare*: its own Work, the
  // parameters and tf only), so that the gates do not wait while a large cloud's points and
  // shape are built; commit then takes it under the lock. A subscription's callbacks never run
  // concurrently (roscpp's default), so each sensor's Work has one user at a time.
  struct Work {
    std::string why;           // non-empty: the message is dropped, for this reason
    ros::Time stamp;           // the message's (its receipt when zero)
    size_t nan_beams = 0, first_nan = 0, skipped = 0;
    std::string frame;         // header.frame_id without a leading '/'
    bool has_origin = false;   // the frame is not the fixed frame: its origin there
    Eigen::Vector3d origin = Eigen::Vector3d::Zero();
    std::shared_ptr<const FilterSnapshot> bodies;  // what the points are filtered against
    SensorFilter filter;
    SensorFilter::Dropped filtered;
    std::vector<Eigen::Vector3d> points;  // kept, in the fixed frame
    bool has_shape = false;    // false: no point kept
    vadop::Shape shape;        // about the points' centroid
    std::shared_ptr<const vadop::PreparedShape> prepared;  // shape grown by prepared_padding
    double prepared_padding = 0.0;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    laser_geometry::LaserProjection projector;  // its cache of a scan's angles
    sensor_msgs::PointCloud2 projected;         // a scan's projection
    VoxelFilter voxels;  // a cloud's
  };
  // The header's stamp (skew) and frame (`to_fixed`: into the fixed frame); false and w.why
  // when the message is to be dropped.
  bool prepareHeader(const std_msgs::Header& h, const ros::Time& receipt, TransformSource& tf, Work& w,
                     Eigen::Isometry3d& to_fixed) const;
  void prepareScan(size_t sensor, const sensor_msgs::LaserScan& msg, const ros::Time& receipt, TransformSource& tf,
                   Work& w) const;
  void prepareCloud(size_t sensor, const sensor_msgs::PointCloud2& msg, const ros::Time& receipt,
                    TransformSource& tf, Work& w) const;
  void prepareMap(size_t sensor, const nav_msgs::OccupancyGrid& msg, const ros::Time& receipt, TransformSource& tf,
                  Work& w) const;
  // w.points become the shape posed at their centroid: balls about each, or boxes of `box`
  // when it is non-zero (a map: turned by `turn`).
  void buildShape(size_t sensor, Work& w, const Eigen::Vector3d& box = Eigen::Vector3d::Zero(),
                  const Eigen::Matrix3d& turn = Eigen::Matrix3d::Identity()) const;
  // Drops w.points within the snapshot's bodies (filter_margin, self_margin).
  void filterPoints(size_t sensor, TransformSource& tf, Work& w) const;
  // Keeps `p` (fixed frame) when within the z band and the library's range (else counts it).
  bool admit(size_t sensor, const Eigen::Vector3d& p, Work& w) const;
  // Under the lock: the prepared message dropped, ignored (out of order) or kept.
  InputResult commit(size_t sensor, Work& w, const ros::Time& receipt);
  // A message through prepare (without `lock`, when given) and commit (under it).
  template <class Msg>
  InputResult receive(size_t sensor, void (SensorsSource::*prepare)(size_t, const Msg&, const ros::Time&,
                                                                   TransformSource&, Work&) const,
                      const Msg& msg, const ros::Time& receipt, TransformSource& tf, std::mutex* lock);
  InputResult dropMessage(size_t sensor, const std::string& why, const ros::Time& receipt);
  void problem(size_t sensor, const std::string& why, const ros::Time& receipt);
  void release(size_t slot);

  std::vector<SensorParams> params_;
  std::string fixed_frame_;
  double max_stamp_skew_;
  std::vector<SensorStatus> status_;
  std::vector<ros::Time> last_stamp_;             // per sensor: of the last accepted message
  std::vector<std::vector<Eigen::Vector3d>> points_;
  std::vector<char> emptied_;  // per sensor: its last accepted message had no point (leaves)
  std::vector<std::unique_ptr<Work>> work_;  // per sensor (LaserProjection does not move)
  FilterProvider filter_provider_;
  std::atomic<double> padding_{0.0};
  int threads_ = 1;  // resolved
};

}  // namespace vadop_ros
