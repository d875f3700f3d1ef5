#include "vadop_ros/sensors_source.h"

#include "../message_checks.h"
#include "../param_reading.h"
#include "source_problem.h"

#include <vadop/error.h>
#include <vadop/world.h>
#include <vadop/shapes.h>

#include <diagnostic_msgs/DiagnosticStatus.h>
#include <diagnostic_updater/DiagnosticStatusWrapper.h>
#include <ros/console.h>
#include <ros/node_handle.h>
#include <sensor_msgs/point_cloud2_iterator.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <set>
#include <utility>

namespace vadop_ros {
namespace {

// A map's default height band (m in the fixed frame) and the height given to its unbounded side.
constexpr double kMapFloor = 0.0, kMapHeight = 2.0;

const char* sensorTypeName(SensorType t) {
  switch (t) {
    case SensorType::kScan: return "scan";
    case SensorType::kCloud: return "cloud";
    case SensorType::kMap: return "map";
  }
  return "?";
}

std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

// The x, y and z fields of a cloud as PointCloud2ConstIterator<float> reads them: FLOAT32, within
// point_step, rows not padded; "" when they are, else why not (naming the field).
std::string cloudLayoutError(const sensor_msgs::PointCloud2& msg) {
  using sensor_msgs::PointField;
  if (msg.is_bigendian) return "is_bigendian: big-endian data is not supported";
  if (msg.point_step == 0) return "point_step is 0";
  for (const char* axis : {"x", "y", "z"}) {
    const PointField* found = nullptr;
    for (const PointField& f : msg.fields) found = f.name == axis ? &f : found;
    if (!found) return std::string("fields: no field \"") + axis + "\"";
    if (found->datatype != PointField::FLOAT32) {
      return std::string("fields[\"") + axis + "\"].datatype is " + std::to_string(found->datatype) + ", not FLOAT32 (7)";
    }
    if (static_cast<uint64_t>(found->offset) + 4 > msg.point_step) {
      return std::string("fields[\"") + axis + "\"].offset " + std::to_string(found->offset) +
             " does not fit in point_step " + std::to_string(msg.point_step);
    }
  }
  const uint64_t row = static_cast<uint64_t>(msg.width) * msg.point_step;
  if (msg.row_step != row) {
    return "row_step " + std::to_string(msg.row_step) + " differs from width x point_step = " + std::to_string(row) +
           " (padded rows are not supported)";
  }
  if (msg.data.size() != row * msg.height) {
    return "data has " + std::to_string(msg.data.size()) + " bytes, row_step x height = " +
           std::to_string(row * msg.height);
  }
  return "";
}

// A scan's fields laser_geometry projects with: "" when usable, else why not.
std::string scanError(const sensor_msgs::LaserScan& msg) {
  const std::pair<const char*, double> values[] = {{"angle_min", msg.angle_min},
                                                    {"angle_increment", msg.angle_increment},
                                                    {"range_min", msg.range_min},
                                                    {"range_max", msg.range_max}};
  for (const auto& [field, v] : values) {
    if (!std::isfinite(v)) return std::string(field) + " is " + number(v) + " (not finite)";
  }
  if (msg.angle_increment == 0.0f && msg.ranges.size() > 1) return "angle_increment is 0";
  return "";
}

}  // namespace

SensorsSource::SensorsSource(std::vector<SensorParams> params, std::string fixed_frame, double max_stamp_skew,
                             int threads)
    : params_(std::move(params)),
      fixed_frame_(std::move(fixed_frame)),
      max_stamp_skew_(max_stamp_skew),
      status_(params_.size()),
      last_stamp_(params_.size()),
      points_(params_.size()),
      emptied_(params_.size(), 0) {
  bodies_.resize(params_.size());  // slot i: sensor i
  for (size_t i = 0; i < params_.size(); ++i) work_.push_back(std::make_unique<Work>());
  threads_ = vadop::threadCount(threads);
}

void SensorsSource::problem(size_t sensor, const std::string& why, const ros::Time& receipt) {
  const SensorParams& p = params_[sensor];
  noteSourceProblem(status_[sensor], "sensor \"" + p.name + "\" (" + p.topic + ")", "sensor", why, receipt);
}

InputResult SensorsSource::dropMessage(size_t sensor, const std::string& why, const ros::Time& receipt) {
  ++status_[sensor].dropped;
  problem(sensor, "message dropped (the previous points stay until the timeout): " + why, receipt);
  return InputResult::kInvalid;
}

bool SensorsSource::prepareHeader(const std_msgs::Header& h, const ros::Time& receipt, TransformSource& tf, Work& w,
                                  Eigen::Isometry3d& to_fixed) const {
  w.why.clear();
  w.nan_beams = w.skipped = 0;
  w.points.clear();
  w.has_shape = false;
  w.filtered = SensorFilter::Dropped();
  w.stamp = h.stamp.isZero() ? receipt : h.stamp;
  if (const std::string why = stampSkewError(w.stamp, receipt, max_stamp_skew_); !why.empty()) {
    w.why = "header.stamp: " + why;
    return false;
  }
  std::string frame = h.frame_id;
  while (!frame.empty() && frame.front() == '/') frame.erase(0, 1);
  if (frame.empty()) {
    w.why = "header.frame_id is empty";
    return false;
  }
  w.frame = frame;
  w.has_origin = false;
  to_fixed = Eigen::Isometry3d::Identity();
  if (frame == fixed_frame_) return true;
  ros::Time tf_stamp;
  std::string error;
  bool found = false;
  try {
    found = tf.lookup(fixed_frame_, frame, w.stamp, to_fixed, tf_stamp, error);
  } catch (const std::exception& e) {
    error = e.what();
  }
  if (!found) w.why = "header.frame_id \"" + frame + "\": no transform to \"" + fixed_frame_ + "\" at its stamp: " + error;
  w.has_origin = found;
  w.origin = to_fixed.translation();
  return found;
}

void SensorsSource::filterPoints(size_t sensor, TransformSource& tf, Work& w) const {
  if (!w.bodies || w.bodies->items.empty() || w.points.empty()) return;
  const SensorParams& sp = params_[sensor];
  try {
    const int self = carrierOf(*w.bodies, w.frame, w.stamp, tf, w.has_origin ? &w.origin : nullptr);
    w.filtered = w.filter.apply(*w.bodies, w.stamp, self, sp.filter_margin, sp.self_margin, w.points, threads_);
  } catch (const std::exception&) {
    // Not expected (finite points, valid motions); the points then stay obstacles, unfiltered.
    w.filtered = SensorFilter::Dropped();
  }
}

bool SensorsSource::admit(size_t sensor, const Eigen::Vector3d& p, Work& w) const {
  const SensorParams& sp = params_[sensor];
  if (!(p.cwiseAbs().maxCoeff() <= vadop::kMaxCoordinate)) {  // false for NaN
    ++w.skipped;
    return false;
  }
  return p.z() >= sp.min_z && p.z() <= sp.max_z;
}

void SensorsSource::buildShape(size_t sensor, Work& w, const Eigen::Vector3d& box, const Eigen::Matrix3d& turn) const {
  if (w.points.empty()) return;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : w.points) centroid += p;
  centroid /= static_cast<double>(w.points.size());
  std::vector<Eigen::Vector3d> local;
  local.reserve(w.points.size());
  for (const Eigen::Vector3d& p : w.points) local.push_back(turn.transpose() * (p - centroid));
  try {
    w.shape = box.isZero() ? vadop::makePointSet(std::move(local), params_[sensor].point_radius)
                           : vadop::makeBoxSet(local, box);
  } catch (const vadop::InvalidArgument& e) {  // cannot happen: the points are finite and in range
    w.why = std::string("points refused by the library: ") + e.what();
    return;
  }
  // The tree built here, in the message's callback (outside the node's lock), for the world.
  w.prepared_padding = padding_.load();
  try {
    w.prepared = vadop::prepareShape(w.prepared_padding > 0.0 ? vadop::inflate(w.shape, w.prepared_padding) : w.shape,
                                     threads_);
  } catch (const vadop::InvalidArgument&) {  // not expected (a valid shape, padding in range)
    w.prepared = nullptr;                     // the cycle prepares it, reporting why
  }
  w.has_shape = true;
  w.pose = Eigen::Isometry3d::Identity();
  w.pose.linear() = turn;
  w.pose.translation() = centroid;
}

InputResult SensorsSource::commit(size_t sensor, Work& w, const ros::Time& receipt) {
  if (!w.why.empty()) return dropMessage(sensor, w.why, receipt);
  SensorStatus& st = status_[sensor];
  // Older than the last accepted one (while that one is not ahead of the clock): out of order.
  const ros::Time& last = last_stamp_[sensor];
  if (!last.isZero() && w.stamp < last && last <= receipt) {
    ++st.out_of_order;
    return InputResult::kOutOfOrder;
  }
  st.points_skipped += w.skipped;
  st.points_filtered_self += w.filtered.self;
  st.points_filtered_others += w.filtered.others;
  if (w.nan_beams > 0) {
    st.beams_nan += w.nan_beams;
    problem(sensor, "ranges[" + std::to_string(w.first_nan) + "] is NaN (" + std::to_string(w.nan_beams) +
                        " NaN beam(s) in this scan give no point; the rest is kept)", receipt);
  }
  ++st.accepted;
  st.last_receipt = receipt;
  last_stamp_[sensor] = w.stamp;
  st.points = w.points.size();
  points_[sensor].swap(w.points);
  if (!w.has_shape) {
    emptied_[sensor] = 1;  // its body leaves at the next expire
    return InputResult::kAccepted;
  }
  emptied_[sensor] = 0;
  SourcedBody& b = bodies_[sensor];
  b.alive = true;
  b.name = params_[sensor].name;
  b.link.clear();
  std::swap(b.shape, w.shape);  // no copy of a large shape under the lock
  b.prepared = std::move(w.prepared);
  b.prepared_padding = w.prepared_padding;
  b.pose = w.pose;
  b.v.setZero();
  b.w.setZero();
  b.stamp = w.stamp;
  ++b.shape_version;
  return InputResult::kAccepted;
}

void SensorsSource::prepareScan(size_t sensor, const sensor_msgs::LaserScan& msg, const ros::Time& receipt,
                                TransformSource& tf, Work& w) const {
  Eigen::Isometry3d to_fixed;
  if (!prepareHeader(msg.header, receipt, tf, w, to_fixed)) return;
  if (const std::string why = scanError(msg); !why.empty()) {
    w.why = why;
    return;
  }
  // REP 117: NaN is an erroneous beam (no point; counted and warned about), +-Inf out of range.
  for (size_t i = 0; i < msg.ranges.size(); ++i) {
    if (!std::isnan(msg.ranges[i])) continue;
    if (w.nan_beams++ == 0) w.first_nan = i;
  }
  // laser_geometry keeps the beams with range_min <= range < range_max (NaN and +-Inf never).
  try {
    w.projector.projectLaser(msg, w.projected, -1.0, laser_geometry::channel_option::None);
  } catch (const std::exception& e) {  // not expected with the fields checked; never into the node
    w.why = std::string("ranges: laser_geometry could not project the scan: ") + e.what();
    return;
  }
  sensor_msgs::PointCloud2ConstIterator<float> x(w.projected, "x"), y(w.projected, "y"), z(w.projected, "z");
  for (; x != x.end(); ++x, ++y, ++z) {
    const Eigen::Vector3d p = to_fixed * Eigen::Vector3d(*x, *y, *z);
    if (admit(sensor, p, w)) w.points.push_back(p);
  }
  filterPoints(sensor, tf, w);
  buildShape(sensor, w);
}

void SensorsSource::prepareCloud(size_t sensor, const sensor_msgs::PointCloud2& msg, const ros::Time& receipt,
                                 TransformSource& tf, Work& w) const {
  Eigen::Isometry3d to_fixed;
  if (!prepareHeader(msg.header, receipt, tf, w, to_fixed)) return;
  if (const std::string why = cloudLayoutError(msg); !why.empty()) {
    w.why = why;
    return;
  }
  sensor_msgs::PointCloud2ConstIterator<float> x(msg, "x"), y(msg, "y"), z(msg, "z");
  for (; x != x.end(); ++x, ++y, ++z) {
    if (!(std::isfinite(*x) && std::isfinite(*y) && std::isfinite(*z))) {  // an organized cloud's "no return"
      ++w.skipped;
      continue;
    }
    const Eigen::Vector3d p = to_fixed * Eigen::Vector3d(*x, *y, *z);
    if (admit(sensor, p, w)) w.points.push_back(p);
  }
  // At most one point per voxel of the fixed frame's grid.
  if (params_[sensor].voxel > 0.0) w.voxels.apply(w.points, params_[sensor].voxel);
  filterPoints(sensor, tf, w);
  buildShape(sensor, w);
}

std::pair<double, double> SensorsSource::mapBand(const SensorParams& p) {
  const bool lo = std::isfinite(p.min_z), hi = std::isfinite(p.max_z);
  if (lo && hi) return {p.min_z, p.max_z};
  if (lo) return {p.min_z, p.min_z + kMapHeight};
  if (hi) return {p.max_z - kMapHeight, p.max_z};
  return {kMapFloor, kMapFloor + kMapHeight};
}

void SensorsSource::prepareMap(size_t sensor, const nav_msgs::OccupancyGrid& msg, const ros::Time& receipt,
                               TransformSource& tf, Work& w) const {
  Eigen::Isometry3d to_fixed;
  if (!prepareHeader(msg.header, receipt, tf, w, to_fixed)) return;
  const nav_msgs::MapMetaData& info = msg.info;
  const uint64_t cells = static_cast<uint64_t>(info.width) * info.height;
  if (msg.data.size() != cells) {
    w.why = "data has " + std::to_string(msg.data.size()) + " cells, width x height = " + std::to_string(cells);
    return;
  }
  if (!(info.resolution > 0.0f && info.resolution <= vadop::kMaxSize)) {
    w.why = "info.resolution is " + number(info.resolution) + " (must be > 0 and finite)";
    return;
  }
  if (!checkPoint(info.origin.position, "info.origin.position", w.why) ||
      !checkQuaternion(info.origin.orientation, "info.origin.orientation", w.why)) {
    return;
  }
  const geometry_msgs::Quaternion& q = info.origin.orientation;
  Eigen::Isometry3d grid = Eigen::Isometry3d::Identity();
  grid.linear() = Eigen::Quaterniond(q.w, q.x, q.y, q.z).normalized().toRotationMatrix();
  grid.translation() = Eigen::Vector3d(info.origin.position.x, info.origin.position.y, info.origin.position.z);
  grid = to_fixed * grid;
  // The cells are boxes over the height band, turned with the grid about the vertical (a
  // grid is level in the fixed frame).
  const auto [z0, z1] = mapBand(params_[sensor]);
  const double res = info.resolution;
  const Eigen::Matrix3d turn =
      Eigen::AngleAxisd(std::atan2(grid.linear()(1, 0), grid.linear()(0, 0)), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const int occupied = params_[sensor].occupied;
  for (size_t i = 0; i < msg.data.size(); ++i) {
    if (msg.data[i] < occupied) continue;  // -1 (unknown) included
    const double cx = (static_cast<double>(i % info.width) + 0.5) * res, cy = (static_cast<double>(i / info.width) + 0.5) * res;
    Eigen::Vector3d c = grid * Eigen::Vector3d(cx, cy, 0.0);
    c.z() = 0.5 * (z0 + z1);
    if (c.cwiseAbs().maxCoeff() <= vadop::kMaxCoordinate) {
      w.points.push_back(c);
    } else {
      ++w.skipped;
    }
  }
  filterPoints(sensor, tf, w);
  buildShape(sensor, w, Eigen::Vector3d(res, res, z1 - z0), turn);
}

template <class Msg>
InputResult SensorsSource::receive(size_t sensor,
                                   void (SensorsSource::*prepare)(size_t, const Msg&, const ros::Time&,
                                                                  TransformSource&, Work&) const,
                                   const Msg& msg, const ros::Time& receipt, TransformSource& tf, std::mutex* lock) {
  Work& w = *work_.at(sensor);
  const auto guard = [lock] { return lock ? std::unique_lock<std::mutex>(*lock) : std::unique_lock<std::mutex>(); };
  {
    const auto held = guard();
    w.bodies = filter_provider_ ? filter_provider_() : nullptr;
  }
  (this->*prepare)(sensor, msg, receipt, tf, w);
  const auto held = guard();
  const InputResult result = commit(sensor, w, receipt);
  w.bodies.reset();  // the snapshot's shapes are not kept alive between messages
  return result;
}

InputResult SensorsSource::onScan(size_t sensor, const sensor_msgs::LaserScan& msg, const ros::Time& receipt,
                                  TransformSource& tf, std::mutex* lock) {
  return receive(sensor, &SensorsSource::prepareScan, msg, receipt, tf, lock);
}

InputResult SensorsSource::onCloud(size_t sensor, const sensor_msgs::PointCloud2& msg, const ros::Time& receipt,
                                   TransformSource& tf, std::mutex* lock) {
  return receive(sensor, &SensorsSource::prepareCloud, msg, receipt, tf, lock);
}

InputResult SensorsSource::onMap(size_t sensor, const nav_msgs::OccupancyGrid& msg, const ros::Time& receipt,
                                 TransformSource& tf, std::mutex* lock) {
  return receive(sensor, &SensorsSource::prepareMap, msg, receipt, tf, lock);
}

bool SensorsSource::stale(size_t sensor, const ros::Time& now) const {
  const SensorStatus& st = status_.at(sensor);
  if (st.last_receipt.isZero()) return true;
  if (params_[sensor].timeout == 0.0) return false;  // a map that never goes stale
  return !receiptFresh(st.last_receipt, now, params_[sensor].timeout);
}

bool SensorsSource::staleInput(const ros::Time& now, const std::function<bool(const std::string& name)>& ignored,
                               std::string& why) const {
  for (size_t s = 0; s < params_.size(); ++s) {
    if (!stale(s, now) || (ignored && ignored(params_[s].name))) continue;
    const SensorStatus& st = status_[s];
    why = "sensor \"" + params_[s].name + "\" (" + params_[s].topic + "): ";
    why += st.last_receipt.isZero() ? std::string("no message yet")
                                    : "no message for " + number(secondsBetween(now, st.last_receipt)) + " s (timeout " +
                                          number(params_[s].timeout) + " s)";
    return true;
  }
  return false;
}

void SensorsSource::release(size_t slot) {
  SourcedBody& b = bodies_[slot];
  const uint64_t version = b.shape_version;  // kept increasing across the slot's lives
  b = SourcedBody();
  b.shape_version = version;
  emptied_[slot] = 0;
}

void SensorsSource::expire(const ros::Time& now, std::vector<size_t>& left) {
  for (size_t s = 0; s < bodies_.size(); ++s) {
    if (!bodies_[s].alive) continue;
    const bool timed_out = params_[s].timeout > 0.0 && !receiptFresh(status_[s].last_receipt, now, params_[s].timeout);
    if (!timed_out && !emptied_[s]) continue;
    if (timed_out) {
      ++status_[s].expired;
      points_[s].clear();
      status_[s].points = 0;
    }
    release(s);
    left.push_back(s);
  }
}

void SensorsSource::drop(size_t slot, const std::string& why, const ros::Time& now) {
  if (slot >= bodies_.size() || !bodies_[slot].alive) return;
  ++status_[slot].dropped;
  problem(slot, "points left out: " + why, now);
  points_[slot].clear();
  status_[slot].points = 0;
  release(slot);
}

void SensorsSource::clear(std::vector<size_t>& left) {
  for (size_t s = 0; s < bodies_.size(); ++s) {
    last_stamp_[s] = ros::Time();
    status_[s].last_receipt = ros::Time();  // stale until its next message
    points_[s].clear();
    status_[s].points = 0;
    if (!bodies_[s].alive) continue;
    release(s);
    left.push_back(s);
  }
}

std::vector<ros::Subscriber> SensorsSource::subscribe(const Wiring& w) {
  std::vector<ros::Subscriber> subs;
  for (size_t s = 0; s < params_.size(); ++s) {
    std::mutex* lock = &w.lock;
    TransformSource* tf = &w.tf;
    // Each message stamped with the node's clock at its receipt, prepared without the lock (its
    // points and shape: milliseconds for a large cloud, which the gates need not wait for),
    // then committed under it.
    auto handler = [this, s, lock, tf](auto receive_one) {
      return [this, s, lock, tf, receive_one](const auto& msg) {
        (this->*receive_one)(s, *msg, ros::Time::now(), *tf, lock);
      };
    };
    const std::string& topic = params_[s].topic;
    const ros::TransportHints hints = ros::TransportHints().tcpNoDelay();
    switch (params_[s].type) {
      case SensorType::kScan:
        subs.push_back(w.nh.subscribe<sensor_msgs::LaserScan>(
            topic, 5, std::function<void(const sensor_msgs::LaserScanConstPtr&)>(handler(&SensorsSource::onScan)),
            ros::VoidConstPtr(), hints));
        break;
      case SensorType::kCloud:
        subs.push_back(w.nh.subscribe<sensor_msgs::PointCloud2>(
            topic, 2, std::function<void(const sensor_msgs::PointCloud2ConstPtr&)>(handler(&SensorsSource::onCloud)),
            ros::VoidConstPtr(), hints));
        break;
      case SensorType::kMap:
        subs.push_back(w.nh.subscribe<nav_msgs::OccupancyGrid>(
            topic, 1, std::function<void(const nav_msgs::OccupancyGridConstPtr&)>(handler(&SensorsSource::onMap)),
            ros::VoidConstPtr(), hints));
        break;
    }
  }
  return subs;
}

void SensorsSource::report(diagnostic_updater::DiagnosticStatusWrapper& stat, const ros::Time& now) const {
  using diagnostic_msgs::DiagnosticStatus;
  unsigned char level = DiagnosticStatus::OK;
  std::string stale_names;
  size_t points = 0;
  for (size_t i = 0; i < params_.size(); ++i) {
    const SensorParams& p = params_[i];
    const SensorStatus& st = status_[i];
    const std::string k = p.name + ": ";
    const bool is_stale = stale(i, now);
    stat.add(k + "topic", p.topic);
    stat.add(k + "type", sensorTypeName(p.type));
    stat.add(k + "points", st.points);
    stat.add(k + "stale", is_stale ? "yes" : "no");
    stat.add(k + "messages accepted", st.accepted);
    stat.add(k + "messages dropped", st.dropped);
    stat.add(k + "messages out of order", st.out_of_order);
    stat.add(k + "beams NaN", st.beams_nan);
    stat.add(k + "points skipped", st.points_skipped);
    stat.add(k + "points filtered (own body)", st.points_filtered_self);
    stat.add(k + "points filtered (other bodies)", st.points_filtered_others);
    stat.add(k + "expired", st.expired);
    stat.add(k + "last problem", st.last_problem.empty() ? std::string("none") : st.last_problem);
    points += st.points;
    if (is_stale) stale_names += (stale_names.empty() ? "" : ", ") + p.name;
    if (is_stale || (!st.last_problem_receipt.isZero() &&
                     secondsBetween(now, st.last_problem_receipt) < BodyRegistry::kInvalidMarkSeconds)) {
      level = DiagnosticStatus::WARN;
    }
  }
  char buf[128];
  std::snprintf(buf, sizeof buf, "%zu point(s) from %zu sensor(s)", points, params_.size());
  std::string summary = buf;
  if (!stale_names.empty()) summary += "; stale (the gates stop): " + stale_names;
  if (level != DiagnosticStatus::OK && stale_names.empty()) summary += "; bad input recently (see last problem)";
  stat.summary(level, summary);
}

namespace {

using XmlRpc::XmlRpcValue;

// The keys of a ~sensors entry; those of one type only are refused on the others.
const std::set<std::string> kSensorKeys = {"name", "type", "topic", "timeout", "point_radius", "min_z", "max_z",
                                           "voxel", "filter_margin", "self_margin", "occupied"};

std::string sensorPath(int i, const XmlRpcValue& e) {
  std::string p = "~sensors[" + std::to_string(i) + "]";
  if (e.getType() == XmlRpcValue::TypeStruct && e.hasMember("name") && e["name"].getType() == XmlRpcValue::TypeString) {
    p += " (\"" + static_cast<std::string>(e["name"]) + "\")";
  }
  return p;
}

std::string sensorName(const XmlRpcValue& e, const std::string& path, std::set<std::string>& names) {
  using namespace param_reading;
  const XmlRpcValue* v = member(e, "name");
  if (!v) fail(path + ".name", "is required (the impacts' body name)");
  const std::string name = toString(*v, path + ".name");
  if (name.empty()) fail(path + ".name", "must not be empty");
  if (name.find_first_of("/ \t\n") != std::string::npos) {
    fail(path + ".name", "must not contain '/' or spaces, got \"" + name + "\"");
  }
  if (!names.insert(name).second) {
    fail(path + ".name", "duplicate name \"" + name + "\" (names are unique among bodies, static obstacles and sensors)");
  }
  return name;
}

SensorType sensorType(const XmlRpcValue& e, const std::string& path) {
  using namespace param_reading;
  const XmlRpcValue* v = member(e, "type");
  if (!v) fail(path + ".type", "is required (scan, cloud or map)");
  const std::string t = toString(*v, path + ".type");
  if (t == "scan") return SensorType::kScan;
  if (t == "cloud") return SensorType::kCloud;
  if (t == "map") return SensorType::kMap;
  fail(path + ".type", "must be scan, cloud or map, got \"" + t + "\"");
}

// Keys that mean something for some types only: refused on the others (a typo'd type would
// otherwise silently ignore them).
void rejectForType(const XmlRpcValue& e, const std::string& path, SensorType type) {
  using namespace param_reading;
  if (type != SensorType::kCloud && member(e, "voxel")) {
    fail(path + ".voxel", std::string("applies to type cloud only, not ") + sensorTypeName(type));
  }
  if (type != SensorType::kMap && member(e, "occupied")) {
    fail(path + ".occupied", std::string("applies to type map only, not ") + sensorTypeName(type));
  }
  if (type == SensorType::kMap && member(e, "point_radius")) {
    fail(path + ".point_radius", "applies to types scan and cloud only (a map's cells are boxes of the cell size)");
  }
}

// The z band: each bound within vadop::kMaxCoordinate, min_z < max_z.
void readBand(const XmlRpcValue& e, const std::string& path, SensorParams& s) {
  using namespace param_reading;
  if (const XmlRpcValue* v = member(e, "min_z")) {
    s.min_z = ranged(v, 0.0, -vadop::kMaxCoordinate, vadop::kMaxCoordinate, false, path + ".min_z");
  }
  if (const XmlRpcValue* v = member(e, "max_z")) {
    s.max_z = ranged(v, 0.0, -vadop::kMaxCoordinate, vadop::kMaxCoordinate, false, path + ".max_z");
  }
  if (!(s.min_z < s.max_z)) fail(path + ".max_z", "must be > min_z (" + num(s.min_z) + "), got " + num(s.max_z));
}

SensorParams parseSensor(const XmlRpcValue& e, const std::string& path, std::set<std::string>& names) {
  using namespace param_reading;
  requireStruct(e, path);
  rejectUnknown(e, kSensorKeys, path);
  SensorParams s;
  s.name = sensorName(e, path, names);
  s.type = sensorType(e, path);
  rejectForType(e, path, s.type);
  const XmlRpcValue* topic = member(e, "topic");
  if (!topic) fail(path + ".topic", "is required");
  s.topic = toString(*topic, path + ".topic");
  checkRosName(s.topic, path + ".topic", "topic");
  // 0 only for a map (never stale): a scan or cloud that stops must stop the gates.
  s.timeout = ranged(member(e, "timeout"), s.timeout, 0.0, 3600.0, s.type != SensorType::kMap, path + ".timeout");
  s.point_radius = ranged(member(e, "point_radius"), s.point_radius, 0.0, 1.0, true, path + ".point_radius");
  readBand(e, path, s);
  s.voxel = ranged(member(e, "voxel"), s.voxel, 0.0, 10.0, false, path + ".voxel");
  s.filter_margin = ranged(member(e, "filter_margin"), s.filter_margin, 0.0, 10.0, false, path + ".filter_margin");
  s.self_margin = ranged(member(e, "self_margin"), s.self_margin, 0.0, 10.0, false, path + ".self_margin");
  if (const XmlRpcValue* v = member(e, "occupied")) {
    if (v->getType() != XmlRpcValue::TypeInt) fail(path + ".occupied", std::string("must be an integer, got ") + typeName(*v));
    s.occupied = static_cast<int>(const_cast<XmlRpcValue&>(*v));
    if (s.occupied < 1 || s.occupied > 100) {
      fail(path + ".occupied", "must be in [1, 100] (an occupancy probability in percent), got " + std::to_string(s.occupied));
    }
  }
  return s;
}


// ~sensors: a list of sensors, after the bodies and static obstacles (their names are taken).
void parseSensors(const XmlRpcValue& list, MonitorParams& out) {
  param_reading::requireArray(list, "~sensors");
  std::set<std::string> names;
  for (const BodyParams& b : out.bodies) names.insert(b.name);
  for (const StaticObstacleParams& o : out.static_obstacles) names.insert(o.name);
  for (int i = 0; i < list.size(); ++i) out.sensors.push_back(parseSensor(list[i], sensorPath(i, list[i]), names));
  checkSelfMargins(out);
}

}  // namespace

// A gated body's ~padding must exceed the self_margin of every sensor it carries: within the
// margin a wall would be taken for the body itself and the gate would go blind at the wall.
// Which body carries a sensor is known only through tf at run time, so at start-up every
// sensor counts as carried by every gated body.
void checkSelfMargins(const MonitorParams& p) {
  const BodyParams* gated = nullptr;
  for (const BodyParams& b : p.bodies) gated = gated ? gated : (b.has_gate ? &b : nullptr);
  if (!gated) return;
  for (size_t i = 0; i < p.sensors.size(); ++i) {
    const SensorParams& s = p.sensors[i];
    if (p.padding > s.self_margin) continue;
    param_reading::fail("~padding", "must exceed ~sensors[" + std::to_string(i) + "] (\"" + s.name + "\").self_margin = " +
                                        param_reading::num(s.self_margin) + " m while the body \"" + gated->name +
                                        "\" has a gate (the sensor may be mounted on it: which body carries a sensor "
                                        "is known only through tf at run time), got " +
                                        param_reading::num(p.padding) +
                                        " (a wall within the margin would be taken for the body and its gate would go blind)");
  }
}

BodiesSourceKind sensorsSourceKind() {
  return {"sensors", parseSensors, [](const MonitorParams& p) -> std::unique_ptr<BodiesSource> {
            return std::make_unique<SensorsSource>(p.sensors, p.fixed_frame, p.max_stamp_skew, p.threads);
          }};
}

}  // namespace vadop_ros
