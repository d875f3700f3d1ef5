#include "vadop_ros/params.h"

#include "param_reading.h"
#include "vadop_ros/source.h"

#include <vadop/error.h>
#include <vadop/world.h>

#include <ros/names.h>
#include <ros/node_handle.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>

namespace vadop_ros {

namespace param_reading {

std::string num(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

double toDouble(const XmlRpcValue& v, const std::string& path) {
  if (v.getType() == XmlRpcValue::TypeDouble) {
    const double d = static_cast<double>(const_cast<XmlRpcValue&>(v));
    if (!std::isfinite(d)) fail(path, "must be a finite number, got " + num(d));
    return d;
  }
  if (v.getType() == XmlRpcValue::TypeInt) return static_cast<int>(const_cast<XmlRpcValue&>(v));
  fail(path, std::string("must be a number, got ") + typeName(v));
}

void requireStruct(const XmlRpcValue& v, const std::string& path) {
  if (v.getType() != XmlRpcValue::TypeStruct) fail(path, std::string("must be a dictionary, got ") + typeName(v));
}

void requireArray(const XmlRpcValue& v, const std::string& path) {
  if (v.getType() != XmlRpcValue::TypeArray) fail(path, std::string("must be a list, got ") + typeName(v));
}

std::string nearestKey(const std::string& key, const std::set<std::string>& known) {
  // Edit distance (insert, delete, substitute one character; swapping two neighbours counts as
  // one edit, the commonest typo), row by row.
  const auto edits = [](const std::string& a, const std::string& b) {
    std::vector<std::vector<size_t>> d(a.size() + 1, std::vector<size_t>(b.size() + 1));
    for (size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
    for (size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
    for (size_t i = 1; i <= a.size(); ++i) {
      for (size_t j = 1; j <= b.size(); ++j) {
        d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1)});
        if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
      }
    }
    return d[a.size()][b.size()];
  };
  // A typo, not another word: at most a third of the key's characters (1 to 3 edits).
  const size_t limit = std::clamp<size_t>(key.size() / 3, 1, 3);
  std::string best;
  size_t best_edits = limit + 1;
  for (const std::string& k : known) {
    const size_t e = edits(key, k);
    if (e < best_edits) {
      best = k;
      best_edits = e;
    }
  }
  return best;
}

void rejectUnknown(const XmlRpcValue& s, const std::set<std::string>& known, const std::string& path) {
  for (auto it = s.begin(); it != s.end(); ++it) {
    if (!known.count(it->first)) {
      std::string list;
      for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
      const std::string near = nearestKey(it->first, known);
      fail((path == "~" ? path : path + ".") + it->first,
           "unknown key" + (near.empty() ? std::string() : "; did you mean \"" + near + "\"?") +
               " (expected one of: " + list + ")");
    }
  }
}

// A topic or parameter name as the node's NodeHandle resolves it (roscpp's rules,
// ros::names::validate: first character a letter or '/', then letters, digits, '_' and '/').
// '~' names are refused too: the NodeHandle the node subscribes and reads parameters with
// throws on them. `what` says what the name is ("topic", "parameter name").
void checkRosName(const std::string& name, const std::string& path, const char* what) {
  if (name.empty()) fail(path, "must not be empty");
  std::string error;
  if (!ros::names::validate(name, error)) {
    fail(path, std::string("must be a valid ROS ") + what + " name (a letter or '/' first, then letters, digits, '_' and '/'), got \"" + name + "\"");
  }
  if (name.front() == '~') {
    fail(path, std::string("must not be a private (~) ") + what + " name, got \"" + name + "\"");
  }
}

double ranged(const XmlRpcValue* v, double def, double lo, double hi, bool lo_open, const std::string& path) {
  if (!v) return def;
  const double d = toDouble(*v, path);
  if ((lo_open ? !(d > lo) : !(d >= lo)) || !(d <= hi)) {
    fail(path, std::string("must be in ") + (lo_open ? "(" : "[") + num(lo) + ", " + num(hi) + "], got " + num(d));
  }
  return d;
}

void readJointTopic(const XmlRpcValue& entry, const std::string& path, const char* key,
                    std::string BodyParams::*topic, BodyParams& b) {
  const XmlRpcValue* j = member(entry, key);
  if (!j) return;
  const std::string field = path + "." + key;
  const std::string& t = b.*topic = toString(*j, field);
  if (t.empty()) fail(field, "must not be empty");
  if (b.has_shape) fail(field, "applies to robot_description bodies only");
  if (b.links_from_tf) fail(field, "give one source of link poses: joints or tf_prefix, not both");
  if (t == b.topic || b.joint_states_topic == b.joint_trajectory_topic) {
    fail(field, "must differ from the body's other topics");
  }
}

}  // namespace param_reading

namespace {

using XmlRpc::XmlRpcValue;
using namespace param_reading;

bool toBool(const XmlRpcValue& v, const std::string& path) {
  if (v.getType() != XmlRpcValue::TypeBoolean) fail(path, std::string("must be true or false, got ") + typeName(v));
  return static_cast<bool>(const_cast<XmlRpcValue&>(v));
}

int toInt(const XmlRpcValue& v, const std::string& path) {
  if (v.getType() != XmlRpcValue::TypeInt) fail(path, std::string("must be an integer, got ") + typeName(v));
  return static_cast<int>(const_cast<XmlRpcValue&>(v));
}

// A tf2 frame id, after its leading '/' (tf1 style) was removed: letters, digits, '_', '-', '.'
// and '/' between non-empty segments; no spaces. Empty only when allow_empty.
void checkFrame(const std::string& frame, const std::string& path, bool allow_empty) {
  if (frame.empty()) {
    if (allow_empty) return;
    fail(path, "must not be empty");
  }
  for (const char c : frame) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
                    c == '-' || c == '.' || c == '/';
    if (!ok) {
      fail(path, "must be a valid tf frame id (letters, digits, '_', '-', '.' and '/'), got \"" + frame + "\"");
    }
  }
  if (frame.front() == '/' || frame.back() == '/' || frame.find("//") != std::string::npos) {
    fail(path, "must be a valid tf frame id (no empty segment between '/'), got \"" + frame + "\"");
  }
}

// tf2 frame ids have no leading '/': the tf1 style is accepted and the slashes removed.
std::string stripLeadingSlashes(std::string s) {
  size_t n = 0;
  while (n < s.size() && s[n] == '/') ++n;
  return s.erase(0, n);
}

// |value| <= limit (values here are already finite).
void checkRange(double value, double limit, const std::string& path, const char* unit) {
  if (!(std::fabs(value) <= limit)) {
    fail(path, "must be within " + num(limit) + " " + unit + " (vadop/error.h), got " + num(value));
  }
}

std::vector<double> numberList(const XmlRpcValue& v, size_t n, const std::string& path) {
  if (v.getType() != XmlRpcValue::TypeArray || static_cast<size_t>(v.size()) != n) {
    fail(path, "must be a list of " + std::to_string(n) + " numbers");
  }
  std::vector<double> out;
  for (int i = 0; i < v.size(); ++i) out.push_back(toDouble(v[i], path + "[" + std::to_string(i) + "]"));
  return out;
}

// A shape dimension: > 0 (>= 0 when zero_ok) and at most vadop::kMaxSize.
double dimension(const XmlRpcValue& v, const std::string& path, bool zero_ok = false) {
  const double d = toDouble(v, path);
  if (zero_ok ? !(d >= 0.0) : !(d > 0.0)) fail(path, std::string("must be a number ") + (zero_ok ? ">= 0" : "> 0") + ", got " + num(d));
  checkRange(d, vadop::kMaxSize, path, "m");
  return d;
}

// {position: [x,y,z], orientation: [x,y,z,w]} or {position: [...], rpy: [r,p,y]}.
Eigen::Isometry3d parsePose(const XmlRpcValue& v, const std::string& path) {
  requireStruct(v, path);
  rejectUnknown(v, {"position", "orientation", "rpy"}, path);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  if (const XmlRpcValue* p = member(v, "position")) {
    const auto xyz = numberList(*p, 3, path + ".position");
    for (int k = 0; k < 3; ++k) {
      checkRange(xyz[k], vadop::kMaxCoordinate, path + ".position[" + std::to_string(k) + "]", "m");
    }
    pose.translation() = Eigen::Vector3d(xyz[0], xyz[1], xyz[2]);
  }
  const XmlRpcValue* q = member(v, "orientation");
  const XmlRpcValue* rpy = member(v, "rpy");
  if (q && rpy) fail(path, "give orientation or rpy, not both");
  if (q) {
    const auto c = numberList(*q, 4, path + ".orientation");
    Eigen::Quaterniond quat(c[3], c[0], c[1], c[2]);
    if (!(quat.norm() > 1e-9)) fail(path + ".orientation", "must not be a zero quaternion");
    if (!std::isfinite(quat.norm())) fail(path + ".orientation", "must have a finite norm (components too large)");
    pose.linear() = quat.normalized().toRotationMatrix();
  } else if (rpy) {
    const auto a = numberList(*rpy, 3, path + ".rpy");
    pose.linear() = (Eigen::AngleAxisd(a[2], Eigen::Vector3d::UnitZ()) *
                     Eigen::AngleAxisd(a[1], Eigen::Vector3d::UnitY()) *
                     Eigen::AngleAxisd(a[0], Eigen::Vector3d::UnitX())).toRotationMatrix();
  }
  return pose;
}

void checkName(const std::string& name, const std::string& path, std::set<std::string>& used) {
  if (name.empty()) fail(path, "must not be empty");
  if (name.find('/') != std::string::npos) fail(path, "must not contain '/', got \"" + name + "\"");
  if (!used.insert(name).second) fail(path, "duplicate body name \"" + name + "\"");
}

std::string substitute(std::string s, int index) {
  const std::string key = "{i}";
  for (size_t pos = s.find(key); pos != std::string::npos; pos = s.find(key, pos)) {
    const std::string idx = std::to_string(index);
    s.replace(pos, key.size(), idx);
    pos += idx.size();
  }
  return s;
}

std::string entryPath(const std::string& list, int i, const XmlRpcValue& entry) {
  std::string p = "~" + list + "[" + std::to_string(i) + "]";
  if (entry.getType() == XmlRpcValue::TypeStruct && entry.hasMember("name") &&
      entry["name"].getType() == XmlRpcValue::TypeString) {
    p += " (\"" + static_cast<std::string>(entry["name"]) + "\")";
  }
  return p;
}

// The names of one body (a template copy after substitution): topics and robot_description
// parameter by roscpp's rules, frame and tf_prefix as tf2 frame ids. `suffix` marks a copy.
void checkBodyNames(const BodyParams& b, const std::string& path, const std::string& suffix) {
  checkFrame(b.frame, path + ".frame" + suffix, b.source != VelocitySource::kTwist);
  if (!b.has_shape) checkRosName(b.robot_description, path + ".robot_description" + suffix, "parameter");
  if (b.links_from_tf) checkFrame(b.tf_prefix, path + ".tf_prefix" + suffix, true);
  for (const SourceKind& kind : sourceKinds()) {
    if (kind.wanted(b)) checkRosName(b.*kind.topic, path + "." + kind.keys.front() + suffix, "topic");
  }
}

GateParams parseGate(const XmlRpcValue& v, const std::string& path, double stale_timeout) {
  requireStruct(v, path);
  rejectUnknown(v, {"cmd_vel_in", "cmd_vel_out", "time_before_collision", "cmd_timeout", "state_timeout", "ignore",
                    "reaction_time", "others_may_stop"},
                path);
  GateParams g;
  for (auto [key, topic] : {std::pair<const char*, std::string*>{"cmd_vel_in", &g.cmd_vel_in}, {"cmd_vel_out", &g.cmd_vel_out}}) {
    const XmlRpcValue* t = member(v, key);
    if (!t) fail(path + "." + key, "is required (a geometry_msgs/Twist topic)");
    *topic = toString(*t, path + "." + key);
  }
  g.time_before_collision = ranged(member(v, "time_before_collision"), g.time_before_collision, 0.0, 60.0, true,
                                   path + ".time_before_collision");
  g.cmd_timeout = ranged(member(v, "cmd_timeout"), g.cmd_timeout, 0.0, 3600.0, true, path + ".cmd_timeout");
  g.state_timeout = ranged(member(v, "state_timeout"), stale_timeout, 0.0, 1e6, true, path + ".state_timeout");
  // At most 2 s: a base that takes longer to execute a command is not one a gate can protect.
  g.reaction_time = ranged(member(v, "reaction_time"), g.reaction_time, 0.0, 2.0, false, path + ".reaction_time");
  if (const XmlRpcValue* m = member(v, "others_may_stop")) g.others_may_stop = toBool(*m, path + ".others_may_stop");
  if (const XmlRpcValue* list = member(v, "ignore")) {
    requireArray(*list, path + ".ignore");
    for (int i = 0; i < list->size(); ++i) {
      const std::string item = path + ".ignore[" + std::to_string(i) + "]";
      g.ignore.push_back(toString((*list)[i], item));
      if (g.ignore.back().empty()) fail(item, "must not be empty (a \"body/link\" pattern, * matches anything)");
    }
  }
  return g;
}

// The gate's topics of one body (a template copy after substitution).
void checkGateNames(const BodyParams& b, const std::string& path, const std::string& suffix) {
  if (!b.has_gate) return;
  checkRosName(b.gate.cmd_vel_in, path + ".gate.cmd_vel_in" + suffix, "topic");
  checkRosName(b.gate.cmd_vel_out, path + ".gate.cmd_vel_out" + suffix, "topic");
  if (b.gate.cmd_vel_in == b.gate.cmd_vel_out) {
    fail(path + ".gate.cmd_vel_out" + suffix, "must differ from cmd_vel_in (the gate would read its own output), got \"" +
                                                  b.gate.cmd_vel_out + "\"");
  }
}

// The keys of a ~bodies entry: the body's own and its input kinds'.
std::set<std::string> bodyKeys() {
  std::set<std::string> keys = {"name", "frame", "shape", "robot_description", "tf_prefix", "count", "gate",
                                "max_linear_decel", "max_angular_decel"};
  for (const SourceKind& kind : sourceKinds()) keys.insert(kind.keys.begin(), kind.keys.end());
  return keys;
}

// The body's geometry: a shape, or a robot_description with its links rigid or from tf.
void parseBodyGeometry(const XmlRpcValue& e, const std::string& path, BodyParams& b) {
  const XmlRpcValue* shape = member(e, "shape");
  const XmlRpcValue* urdf = member(e, "robot_description");
  if (shape && urdf) fail(path, "give one geometry source: shape or robot_description, not both");
  if (!shape && !urdf) fail(path + ".shape", "is required (or robot_description): the body's geometry");
  if (shape) {
    b.has_shape = true;
    b.shape = parseShape(*shape, path + ".shape");
  } else {
    b.robot_description = toString(*urdf, path + ".robot_description");
    if (b.robot_description.empty()) fail(path + ".robot_description", "must not be empty");
  }
  if (const XmlRpcValue* p = member(e, "tf_prefix")) {
    if (shape) fail(path + ".tf_prefix", "applies to robot_description bodies only");
    b.tf_prefix = toString(*p, path + ".tf_prefix");
    b.links_from_tf = true;
    while (!b.tf_prefix.empty() && b.tf_prefix.back() == '/') b.tf_prefix.pop_back();
    b.tf_prefix = stripLeadingSlashes(b.tf_prefix);
  }
}

// The body's decelerations: both or neither, since braking along an arc needs both (a body
// given one would silently brake at once in the other). The upper bounds (about 10 g, and
// 1000 rad/s^2) are beyond any base: a larger value is a unit mistake, not a robot.
void parseBraking(const XmlRpcValue& e, const std::string& path, BodyParams& b) {
  const XmlRpcValue* linear = member(e, "max_linear_decel");
  const XmlRpcValue* angular = member(e, "max_angular_decel");
  if (linear && !angular) {
    fail(path + ".max_angular_decel", "is required with max_linear_decel (give both decelerations or neither)");
  }
  if (angular && !linear) {
    fail(path + ".max_linear_decel", "is required with max_angular_decel (give both decelerations or neither)");
  }
  if (!linear) return;
  b.max_linear_decel = ranged(linear, 0.0, 0.0, 100.0, true, path + ".max_linear_decel");
  b.max_angular_decel = ranged(angular, 0.0, 0.0, 1000.0, true, path + ".max_angular_decel");
}

// One ~bodies entry (a template before its copies): its own keys, then each input kind's.
BodyParams parseBody(const XmlRpcValue& e, const std::string& path, double stale_timeout) {
  requireStruct(e, path);
  static const std::set<std::string> keys = bodyKeys();
  rejectUnknown(e, keys, path);
  BodyParams b;
  const XmlRpcValue* name = member(e, "name");
  if (!name) fail(path + ".name", "is required");
  b.name = toString(*name, path + ".name");
  if (const XmlRpcValue* f = member(e, "frame")) b.frame = stripLeadingSlashes(toString(*f, path + ".frame"));
  parseBodyGeometry(e, path, b);
  for (const SourceKind& kind : sourceKinds()) kind.parse(e, path, b);
  parseBraking(e, path, b);
  if (const XmlRpcValue* g = member(e, "gate")) {
    b.has_gate = true;
    b.gate = parseGate(*g, path + ".gate", stale_timeout);
  }
  return b;
}

// The entry's count (0: a single body, no template), checked with the number of bodies so far.
int parseCount(const XmlRpcValue& e, const std::string& path, const BodyParams& b, size_t bodies_so_far) {
  int count = 0;
  if (const XmlRpcValue* c = member(e, "count")) {
    count = toInt(*c, path + ".count");
    if (count < 1 || count > kMaxBodies) {
      fail(path + ".count", "must be in [1, " + std::to_string(kMaxBodies) + "], got " + std::to_string(count));
    }
    if (b.name.find("{i}") == std::string::npos) {
      fail(path + ".name", "must contain {i} when count is given (each copy needs its own name)");
    }
  }
  // Checked before any copy is made: each moving body is one subscription (see kMaxBodies).
  const size_t total = bodies_so_far + static_cast<size_t>(std::max(count, 1));
  if (total > static_cast<size_t>(kMaxBodies)) {
    fail(path + (count > 0 ? ".count" : ""), "makes " + std::to_string(total) + " moving bodies, more than the limit of " +
                                                 std::to_string(kMaxBodies) +
                                                 " (each is a topic subscription; ROS start-up time grows with their square)");
  }
  return count;
}

// Copy k of a template: {i} replaced by k in its name, frames, topics and patterns.
BodyParams templateCopy(const BodyParams& b, int k) {
  BodyParams copy = b;
  copy.name = substitute(b.name, k);
  copy.frame = substitute(b.frame, k);
  copy.robot_description = substitute(b.robot_description, k);
  copy.tf_prefix = substitute(b.tf_prefix, k);
  for (const SourceKind& kind : sourceKinds()) {
    if (kind.wanted(b)) copy.*kind.topic = substitute(b.*kind.topic, k);
  }
  copy.gate.cmd_vel_in = substitute(b.gate.cmd_vel_in, k);
  copy.gate.cmd_vel_out = substitute(b.gate.cmd_vel_out, k);
  for (std::string& pattern : copy.gate.ignore) pattern = substitute(pattern, k);
  return copy;
}

void parseBodies(const XmlRpcValue& list, MonitorParams& out, std::set<std::string>& names) {
  requireArray(list, "~bodies");
  for (int i = 0; i < list.size(); ++i) {
    const XmlRpcValue& e = list[i];
    const std::string path = entryPath("bodies", i, e);
    BodyParams b = parseBody(e, path, out.stale_timeout);
    const int count = parseCount(e, path, b, out.bodies.size());
    if (count == 0) {
      checkName(b.name, path + ".name", names);
      checkBodyNames(b, path, "");
      checkGateNames(b, path, "");
      out.bodies.push_back(std::move(b));
      continue;
    }
    out.bodies.reserve(out.bodies.size() + static_cast<size_t>(count));
    for (int k = 0; k < count; ++k) {
      BodyParams copy = templateCopy(b, k);
      const std::string suffix = " (copy " + std::to_string(k) + ")";
      checkName(copy.name, path + ".name" + suffix, names);
      checkBodyNames(copy, path, suffix);
      checkGateNames(copy, path, suffix);
      out.bodies.push_back(std::move(copy));
    }
  }
}

void parseObstacles(const XmlRpcValue& list, MonitorParams& out, std::set<std::string>& names) {
  requireArray(list, "~static_obstacles");
  for (int i = 0; i < list.size(); ++i) {
    const XmlRpcValue& e = list[i];
    const std::string path = entryPath("static_obstacles", i, e);
    requireStruct(e, path);
    rejectUnknown(e, {"name", "shape", "robot_description", "pose"}, path);
    StaticObstacleParams o;
    const XmlRpcValue* name = member(e, "name");
    if (!name) fail(path + ".name", "is required");
    o.name = toString(*name, path + ".name");
    checkName(o.name, path + ".name", names);
    const XmlRpcValue* shape = member(e, "shape");
    const XmlRpcValue* urdf = member(e, "robot_description");
    if (shape && urdf) fail(path, "give one geometry source: shape or robot_description, not both");
    if (!shape && !urdf) fail(path + ".shape", "is required (or robot_description)");
    if (shape) {
      o.has_shape = true;
      o.shape = parseShape(*shape, path + ".shape");
    } else {
      o.robot_description = toString(*urdf, path + ".robot_description");
      checkRosName(o.robot_description, path + ".robot_description", "parameter");
    }
    if (const XmlRpcValue* p = member(e, "pose")) o.pose = parsePose(*p, path + ".pose");
    out.static_obstacles.push_back(std::move(o));
  }
}

// The node's own keys and those of the body-set kinds (bodiesSourceKinds(): "tracks").
std::set<std::string> makeTopLevelKeys() {
  std::set<std::string> keys = {
      "fixed_frame", "rate", "horizon", "padding", "stale_timeout", "max_stamp_skew", "axes", "phi_deg", "threads", "ingest_threads", "ingest_udp", "broad_phase", "time_slices",
      "coherence_clearance", "coherence_lookahead",
      "self_collision", "ignore_pairs", "bodies", "static_obstacles", "log_impacts",
      "publish_markers", "region", "region_margin",
      // set by diagnostic_updater and dynamic_reconfigure themselves
      "diagnostic_period"};
  for (const BodiesSourceKind& kind : bodiesSourceKinds()) keys.insert(kind.name);
  return keys;
}

const std::set<std::string>& topLevelKeys() {
  static const std::set<std::string> keys = makeTopLevelKeys();
  return keys;
}

}  // namespace

vadop::Shape parseShape(const XmlRpcValue& v, const std::string& path) {
  requireStruct(v, path);
  const XmlRpcValue* type = member(v, "type");
  if (!type) fail(path + ".type", "is required (sphere, box, cylinder or capsule)");
  const std::string t = toString(*type, path + ".type");
  auto need = [&](const char* key) -> const XmlRpcValue& {
    const XmlRpcValue* m = member(v, key);
    if (!m) fail(path + "." + key, "is required for a " + t);
    return *m;
  };
  try {
    if (t == "sphere") {
      rejectUnknown(v, {"type", "radius"}, path);
      return vadop::makeSphere(dimension(need("radius"), path + ".radius"));
    }
    if (t == "box") {
      rejectUnknown(v, {"type", "size"}, path);
      const auto s = numberList(need("size"), 3, path + ".size");
      for (int k = 0; k < 3; ++k) {
        if (!(s[k] > 0.0)) fail(path + ".size[" + std::to_string(k) + "]", "must be > 0, got " + num(s[k]));
        checkRange(s[k], vadop::kMaxSize, path + ".size[" + std::to_string(k) + "]", "m");
      }
      return vadop::makeBox(Eigen::Vector3d(s[0], s[1], s[2]));
    }
    if (t == "cylinder" || t == "capsule") {
      rejectUnknown(v, {"type", "radius", "length"}, path);
      const double r = dimension(need("radius"), path + ".radius");
      const double l = dimension(need("length"), path + ".length", t == "capsule");
      return t == "cylinder" ? vadop::makeCylinder(r, l) : vadop::makeCapsule(r, l);
    }
  } catch (const vadop::InvalidArgument& e) {
    fail(path, e.what());
  }
  fail(path + ".type", "must be sphere, box, cylinder or capsule, got \"" + t + "\"");
}

void checkPredictorParams(const MonitorParams& p) {
  // The library validates the pair (pool size, phi >= covering radius) when the world is
  // built; the monitor builds it with these values and reports its message under ~axes/~phi_deg.
  if (p.axes < 3 || p.axes > 4096) fail("~axes", "must be an integer in [3, 4096], got " + std::to_string(p.axes));
  if (!(p.phi_deg >= 0.0 && p.phi_deg < 90.0)) fail("~phi_deg", "must be in [0, 90), got " + num(p.phi_deg));
  try {
    vadop::parseBroadPhaseKind(p.broad_phase);
  } catch (const vadop::InvalidArgument& e) {
    fail("~broad_phase", e.what());
  }
  if (p.time_slices < 1 || p.time_slices > vadop::kMaxTimeSlices) {
    fail("~time_slices", "must be an integer in [1, " + std::to_string(vadop::kMaxTimeSlices) +
                             "] (1: no cull), got " + std::to_string(p.time_slices));
  }
  if (p.threads < 0 || p.threads > vadop::kMaxThreads) {
    fail("~threads", "must be an integer in [0, " + std::to_string(vadop::kMaxThreads) +
                         "] (0: one per hardware thread), got " + std::to_string(p.threads));
  }
  if (p.ingest_threads < 0 || p.ingest_threads > kMaxIngestThreads) {
    fail("~ingest_threads", "must be an integer in [0, " + std::to_string(kMaxIngestThreads) +
                                "] (0: on the receiving thread), got " + std::to_string(p.ingest_threads));
  }
  if (!(p.coherence_clearance >= 0.0 && p.coherence_clearance <= 10.0)) {
    fail("~coherence_clearance", "must be in [0, 10], got " + num(p.coherence_clearance));
  }
  if (p.coherence_clearance > 0.0 && p.coherence_clearance < 0.001) {
    fail("~coherence_clearance", "must be 0 (off) or in [0.001, 10] m, got " + num(p.coherence_clearance));
  }
  if (!(p.coherence_lookahead >= 0.0 && p.coherence_lookahead <= 10.0)) {
    fail("~coherence_lookahead", "must be in [0, 10], got " + num(p.coherence_lookahead));
  }
}

// ~region {min: [x, y, z], max: [x, y, z]} (fixed frame, each min below its max) and
// ~region_margin (m, with a region only).
static void parseRegion(const XmlRpcValue& root, MonitorParams& p) {
  const XmlRpcValue* region = member(root, "region");
  if (const XmlRpcValue* m = member(root, "region_margin")) {
    if (!region) fail("~region_margin", "applies with ~region only");
    p.region_margin = ranged(m, 0.0, 0.0, 1e4, false, "~region_margin");
  }
  if (!region) return;
  requireStruct(*region, "~region");
  rejectUnknown(*region, {"min", "max"}, "~region");
  for (const char* key : {"min", "max"}) {
    const XmlRpcValue* corner = member(*region, key);
    if (!corner) fail(std::string("~region.") + key, "is required ([x, y, z] in the fixed frame)");
    const auto xyz = numberList(*corner, 3, std::string("~region.") + key);
    for (int k = 0; k < 3; ++k) {
      checkRange(xyz[k], vadop::kMaxCoordinate, std::string("~region.") + key + "[" + std::to_string(k) + "]", "m");
      (std::string(key) == "min" ? p.region.min : p.region.max)[k] = xyz[k];
    }
  }
  for (int k = 0; k < 3; ++k) {
    if (!(p.region.min[k] < p.region.max[k])) {
      fail("~region.max[" + std::to_string(k) + "]", "must be above min[" + std::to_string(k) + "] (" +
                                                        num(p.region.min[k]) + "), got " + num(p.region.max[k]));
    }
  }
  p.region.bounded = true;
}

MonitorParams parseParams(const XmlRpcValue& root) {
  MonitorParams p;
  if (root.getType() == XmlRpcValue::TypeInvalid) return p;
  requireStruct(root, "~");
  rejectUnknown(root, topLevelKeys(), "~");
  if (const XmlRpcValue* v = member(root, "fixed_frame")) {
    p.fixed_frame = toString(*v, "~fixed_frame");
    p.fixed_frame = stripLeadingSlashes(p.fixed_frame);  // tf2 frames have no leading '/'
    checkFrame(p.fixed_frame, "~fixed_frame", false);
  }
  // [0.1, 1000] Hz, the range of cfg/Monitor.cfg (the timer's period 1/rate must be a valid
  // ros::Duration and the node must cycle).
  p.rate = ranged(member(root, "rate"), p.rate, kMinRate, kMaxRate, false, "~rate");
  p.horizon = ranged(member(root, "horizon"), p.horizon, 0.0, 60.0, false, "~horizon");
  p.padding = ranged(member(root, "padding"), p.padding, 0.0, 10.0, false, "~padding");
  p.stale_timeout = ranged(member(root, "stale_timeout"), p.stale_timeout, 0.0, 1e6, true, "~stale_timeout");
  p.max_stamp_skew = ranged(member(root, "max_stamp_skew"), p.max_stamp_skew, 0.0, 3600.0, true, "~max_stamp_skew");
  const vadop::VadopConfig vadop_defaults;
  p.axes = vadop_defaults.axes;
  p.phi_deg = vadop_defaults.phi_deg;
  if (const XmlRpcValue* v = member(root, "axes")) p.axes = toInt(*v, "~axes");
  if (const XmlRpcValue* v = member(root, "phi_deg")) p.phi_deg = toDouble(*v, "~phi_deg");
  if (const XmlRpcValue* v = member(root, "threads")) p.threads = toInt(*v, "~threads");
  if (const XmlRpcValue* v = member(root, "ingest_threads")) p.ingest_threads = toInt(*v, "~ingest_threads");
  if (const XmlRpcValue* v = member(root, "ingest_udp")) p.ingest_udp = toBool(*v, "~ingest_udp");
  if (const XmlRpcValue* v = member(root, "broad_phase")) p.broad_phase = toString(*v, "~broad_phase");
  if (const XmlRpcValue* v = member(root, "time_slices")) p.time_slices = toInt(*v, "~time_slices");
  if (const XmlRpcValue* v = member(root, "coherence_clearance")) {
    p.coherence_clearance = toDouble(*v, "~coherence_clearance");
  }
  if (const XmlRpcValue* v = member(root, "coherence_lookahead")) {
    p.coherence_lookahead = toDouble(*v, "~coherence_lookahead");
  }
  checkPredictorParams(p);
  if (const XmlRpcValue* v = member(root, "self_collision")) p.self_collision = toBool(*v, "~self_collision");
  if (const XmlRpcValue* v = member(root, "log_impacts")) p.log_impacts = toBool(*v, "~log_impacts");
  if (const XmlRpcValue* v = member(root, "publish_markers")) p.publish_markers = toBool(*v, "~publish_markers");
  parseRegion(root, p);

  if (const XmlRpcValue* v = member(root, "ignore_pairs")) {
    requireArray(*v, "~ignore_pairs");
    for (int i = 0; i < v->size(); ++i) {
      const std::string path = "~ignore_pairs[" + std::to_string(i) + "]";
      const XmlRpcValue& pair = (*v)[i];
      if (pair.getType() != XmlRpcValue::TypeArray || pair.size() != 2) {
        fail(path, "must be a list of two patterns [\"body/link\", \"body/link\"] (* matches anything)");
      }
      const std::string a = toString(pair[0], path + "[0]");
      const std::string b = toString(pair[1], path + "[1]");
      if (a.empty() || b.empty()) fail(path, "patterns must not be empty");
      p.ignore_pairs.emplace_back(a, b);
    }
  }
  std::set<std::string> names;
  if (const XmlRpcValue* v = member(root, "bodies")) parseBodies(*v, p, names);
  if (const XmlRpcValue* v = member(root, "static_obstacles")) parseObstacles(*v, p, names);
  for (const BodiesSourceKind& kind : bodiesSourceKinds()) {
    if (const XmlRpcValue* v = member(root, kind.name)) kind.parse(*v, p);
  }
  return p;
}

std::vector<std::string> paramWarnings(const MonitorParams& params) {
  std::vector<std::string> out;
  for (const BodyParams& b : params.bodies) {
    if (b.has_gate && !b.hasBraking()) {
      out.push_back("gate of \"" + b.name +
                    "\": no braking model (max_linear_decel / max_angular_decel not given): commands are checked as "
                    "held over time_before_collision, starting after reaction_time");
    }
  }
  return out;
}

MonitorParams loadParams(const ros::NodeHandle& private_nh) {
  XmlRpcValue root;
  if (!private_nh.getParam(private_nh.getNamespace(), root)) return parseParams(XmlRpcValue());
  return parseParams(root);
}

}  // namespace vadop_ros
