#include "vadop_ros/markers.h"

#include "vadop_ros/label_layout.h"

#include <cmath>
#include <cstdio>
#include <map>
#include <utility>
#include <vector>
#include <algorithm>

namespace vadop_ros {
namespace {

using visualization_msgs::Marker;

void setPose(Marker& m, const Eigen::Isometry3d& pose) {
  const Eigen::Quaterniond q(pose.linear());
  m.pose.position.x = pose.translation().x();
  m.pose.position.y = pose.translation().y();
  m.pose.position.z = pose.translation().z();
  m.pose.orientation.x = q.x();
  m.pose.orientation.y = q.y();
  m.pose.orientation.z = q.z();
  m.pose.orientation.w = q.w();
}

void setColour(Marker& m, const std::array<float, 3>& c, float a) {
  m.color.r = c[0];
  m.color.g = c[1];
  m.color.b = c[2];
  m.color.a = a;
}

// A mesh without a mesh resource (a sensor's points or a map's cells: vadop::makePointSet /
// makeBoxSet) as one marker: a SPHERE_LIST of its points (balls of its margin) when every
// triangle is a point, else a TRIANGLE_LIST of its faces (margin not drawn). False: no triangle.
bool addMeshList(visualization_msgs::MarkerArray& out, Marker base, const vadop::Shape& s) {
  if (s.triangles.empty()) return false;
  const bool points = std::all_of(s.triangles.begin(), s.triangles.end(),
                                  [](const std::array<int, 3>& t) { return t[0] == t[1] && t[1] == t[2]; });
  base.type = points ? Marker::SPHERE_LIST : Marker::TRIANGLE_LIST;
  base.scale.x = base.scale.y = base.scale.z = points ? 2.0 * std::max(s.margin, 1e-3) : 1.0;
  base.points.reserve(s.triangles.size() * (points ? 1 : 3));
  for (const std::array<int, 3>& t : s.triangles) {
    for (int k = 0; k < (points ? 1 : 3); ++k) {
      const Eigen::Vector3d& v = s.points[static_cast<size_t>(t[k])];
      geometry_msgs::Point p;
      p.x = v.x();
      p.y = v.y();
      p.z = v.z();
      base.points.push_back(p);
    }
  }
  out.markers.push_back(std::move(base));
  return true;
}

// Appends the markers drawing `e`'s shape at `pose`.
void addShape(visualization_msgs::MarkerArray& out, Marker base, const MarkerElement& e,
              const Eigen::Isometry3d& pose) {
  const vadop::Shape& s = e.shape;
  const double m = s.margin;
  setPose(base, pose);
  switch (s.type) {
    case vadop::ShapeType::kSphere:
      base.type = Marker::SPHERE;
      base.scale.x = base.scale.y = base.scale.z = 2.0 * (s.radius + m);
      out.markers.push_back(base);
      return;
    case vadop::ShapeType::kBox:
      base.type = Marker::CUBE;
      base.scale.x = 2.0 * (s.half_extents.x() + m);
      base.scale.y = 2.0 * (s.half_extents.y() + m);
      base.scale.z = 2.0 * (s.half_extents.z() + m);
      out.markers.push_back(base);
      return;
    case vadop::ShapeType::kCylinder:
      base.type = Marker::CYLINDER;
      base.scale.x = base.scale.y = 2.0 * (s.radius + m);
      base.scale.z = 2.0 * (s.half_length + m);
      out.markers.push_back(base);
      return;
    case vadop::ShapeType::kCapsule: {
      const double r = s.radius + m;
      base.type = Marker::CYLINDER;
      base.scale.x = base.scale.y = 2.0 * r;
      base.scale.z = std::max(2.0 * s.half_length, 1e-4);
      out.markers.push_back(base);
      for (const double z : {-s.half_length, s.half_length}) {
        Marker cap = base;
        cap.id = base.id + 1 + (z > 0 ? 1 : 0);
        cap.type = Marker::SPHERE;
        cap.scale.x = cap.scale.y = cap.scale.z = 2.0 * r;
        setPose(cap, pose * Eigen::Translation3d(0.0, 0.0, z));
        out.markers.push_back(cap);
      }
      return;
    }
    case vadop::ShapeType::kMesh:
      if (!e.mesh_uri.empty()) {
        base.type = Marker::MESH_RESOURCE;
        base.mesh_resource = e.mesh_uri;
        base.scale.x = e.mesh_scale.x();
        base.scale.y = e.mesh_scale.y();
        base.scale.z = e.mesh_scale.z();
        out.markers.push_back(base);
        return;
      }
      if (addMeshList(out, base, s)) return;
      break;
    case vadop::ShapeType::kConvex:
      break;
  }
  // No primitive to draw: the bounding sphere.
  base.type = Marker::SPHERE;
  base.scale.x = base.scale.y = base.scale.z = 2.0 * s.bounding_radius;
  out.markers.push_back(base);
}

geometry_msgs::Point point(const Eigen::Vector3d& p) {
  geometry_msgs::Point out;
  out.x = p.x();
  out.y = p.y();
  out.z = p.z();
  return out;
}

std::string label(const std::string& body, const std::string& link) {
  return link.empty() ? body : body + "/" + link;
}

// The header, namespace and action every marker of `ns` shares.
Marker baseMarker(const MarkerInput& in, const std::string& ns) {
  Marker base;
  base.header.frame_id = in.frame;
  base.header.stamp = in.stamp;
  base.ns = ns;
  base.action = Marker::ADD;
  return base;
}

// Where `e` is at time t: on its path when it follows one, else by its motion.
Eigen::Isometry3d poseOf(const MarkerElement& e, double t) {
  return e.path_pose ? e.path_pose(t) : e.motion.poseAt(t);
}

// The shape of `e` at time t, faded to `alpha`, with the next id of its namespace (a shape
// takes three ids: capsules use id + 1 and id + 2).
void addShapeAt(visualization_msgs::MarkerArray& out, const Marker& base, int& id, const MarkerElement& e,
                const std::array<float, 3>& colour, float alpha, double t) {
  Marker shape = base;
  shape.id = id;
  id += 3;
  setColour(shape, colour, alpha);
  addShape(out, shape, e, poseOf(e, t));
}

// A path's own poses inside (t0, t1), at most kPathGhosts of them evenly picked: the curve the
// prediction follows, drawn faintly.
void addPathGhosts(visualization_msgs::MarkerArray& out, const Marker& base, int& id, const MarkerElement& e,
                   const std::array<float, 3>& colour, double t0, double t1) {
  std::vector<double> inside;
  for (const double t : e.path_times) {
    if (t > t0 && t < t1) inside.push_back(t);
  }
  const size_t n = std::min(inside.size(), static_cast<size_t>(kPathGhosts));
  for (size_t g = 0; g < n; ++g) {
    addShapeAt(out, base, id, e, colour, 0.15f, inside[(g + 1) * inside.size() / (n + 1)]);
  }
}

// The line the element's origin follows over the horizon (finer along a path, which bends).
void addTrajectoryLine(visualization_msgs::MarkerArray& out, const Marker& base, int& id, const MarkerElement& e,
                       const std::array<float, 3>& colour, const MarkerInput& in) {
  Marker path = base;
  path.id = id++;
  path.type = Marker::LINE_STRIP;
  path.scale.x = 0.03;
  setColour(path, colour, 0.9f);
  path.pose.orientation.w = 1.0;
  const int samples = e.path_pose ? 48 : 12;
  for (int k = 0; k <= samples; ++k) {
    const double t = in.t0 + in.horizon * k / samples;
    path.points.push_back(point(poseOf(e, t).translation()));
  }
  out.markers.push_back(path);
}

// One element: its shape now; a moving one also at the horizon's end, its path's poses between
// and the line its origin follows.
void addElementMarkers(visualization_msgs::MarkerArray& out, const MarkerInput& in, const MarkerElement& e, int& id) {
  const auto colour = impactColour(e.soonest, in.horizon);
  Marker base = baseMarker(in, e.body);
  base.frame_locked = false;
  addShapeAt(out, base, id, e, colour, e.is_static ? 0.9f : 0.8f, in.t0);
  if (e.is_static) return;
  const bool moves = e.path_pose || e.motion.linear_velocity.squaredNorm() > 0.0 || e.motion.isRotating();
  if (!moves || in.horizon <= 0.0) return;
  const double t1 = in.t0 + in.horizon;
  addShapeAt(out, base, id, e, colour, 0.25f, t1);
  if (e.path_pose) addPathGhosts(out, base, id, e, colour, in.t0, t1);
  addTrajectoryLine(out, base, id, e, colour, in);
}

// One impact in namespace "impacts": a dot at its point and an arrow along its normal (ids id
// and id + 1).
void addImpactMarkers(visualization_msgs::MarkerArray& out, const MarkerInput& in, const vadop::Impact& imp, int& id) {
  const auto colour = impactColour(imp.time_to_impact, in.horizon);
  Marker base = baseMarker(in, "impacts");
  base.pose.orientation.w = 1.0;

  Marker dot = base;
  dot.id = id++;
  dot.type = Marker::SPHERE;
  dot.pose.position = imp.point;
  dot.scale.x = dot.scale.y = dot.scale.z = 0.12;
  setColour(dot, colour, 1.0f);
  out.markers.push_back(dot);

  Marker arrow = base;
  arrow.id = id++;
  arrow.type = Marker::ARROW;
  arrow.points.push_back(imp.point);
  geometry_msgs::Point tip = imp.point;
  tip.x += 0.4 * imp.normal.x;
  tip.y += 0.4 * imp.normal.y;
  tip.z += 0.4 * imp.normal.z;
  arrow.points.push_back(tip);
  arrow.scale.x = 0.03;  // shaft diameter
  arrow.scale.y = 0.07;  // head diameter
  arrow.scale.z = 0.1;   // head length
  setColour(arrow, colour, 1.0f);
  out.markers.push_back(arrow);
}

// The soonest impact of each body pair (either order), soonest first (ties: by label text).
std::vector<const vadop::Impact*> soonestPerPair(const vadop::ImpactArray& impacts) {
  std::map<std::pair<std::string, std::string>, const vadop::Impact*> soonest;
  for (const vadop::Impact& imp : impacts.impacts) {
    const auto key = std::minmax(imp.body_a, imp.body_b);
    const vadop::Impact*& s = soonest[{key.first, key.second}];
    if (!s || imp.time_to_impact < s->time_to_impact) s = &imp;
  }
  std::vector<const vadop::Impact*> out;
  for (const auto& kv : soonest) out.push_back(kv.second);
  std::stable_sort(out.begin(), out.end(), [](const vadop::Impact* a, const vadop::Impact* b) {
    return a->time_to_impact < b->time_to_impact;
  });
  return out;
}

// One label per body pair in namespace "impacts" (ids from id on): its soonest link pair and time,
// above that impact's point, stacked so that no two labels overlap (label_layout.h).
void addPairLabels(visualization_msgs::MarkerArray& out, const MarkerInput& in, int& id) {
  const std::vector<const vadop::Impact*> pairs = soonestPerPair(*in.impacts);
  std::vector<Eigen::Vector3d> anchors;
  std::vector<std::string> texts;
  for (const vadop::Impact* imp : pairs) {
    anchors.emplace_back(imp->point.x, imp->point.y, imp->point.z);
    texts.push_back(pairLabel(*imp));
  }
  const std::vector<LabelBox> boxes = layoutLabels(anchors, texts, kLabelHeight, kLabelRaise);
  Marker base = baseMarker(in, "impacts");
  base.pose.orientation.w = 1.0;
  for (size_t k = 0; k < boxes.size(); ++k) {
    Marker text = base;
    text.id = id++;
    text.type = Marker::TEXT_VIEW_FACING;
    text.pose.position = point(boxes[k].centre);
    text.scale.z = kLabelHeight;
    text.text = texts[k];
    setColour(text, {1.0f, 1.0f, 1.0f}, 1.0f);
    out.markers.push_back(text);
  }
}

}  // namespace

std::string pairLabel(const vadop::Impact& imp) {
  char secs[32];
  std::snprintf(secs, sizeof secs, ": %.2f s", imp.time_to_impact);
  return label(imp.body_a, imp.link_a) + " <-> " + label(imp.body_b, imp.link_b) + secs;
}

namespace {

// "r2 in 0.80 s" for the contact that limits a gate, empty when none does.
std::string limitingContact(const vadop::GateState& s) {
  if (s.limiting_body.empty()) return "";
  char secs[48];
  std::snprintf(secs, sizeof secs, " in %.2f s", s.time_to_contact);
  return label(s.limiting_body, s.limiting_link) + (std::isfinite(s.time_to_contact) ? secs : "");
}

}  // namespace

std::string gateDecisionText(const vadop::GateState& s) {
  using G = vadop::GateState;
  const std::string contact = limitingContact(s);
  if (s.reason == G::REASON_CLEAR) return "clear";
  if (s.reason == G::REASON_STOP) return contact.empty() ? "stop" : "stop: " + contact;
  if (s.reason == G::REASON_SLOW) {
    char pct[32];
    std::snprintf(pct, sizeof pct, "slow %.0f%%", 100.0 * s.scale);
    return contact.empty() ? std::string(pct) : std::string(pct) + ": " + contact;
  }
  return s.detail.empty() ? s.reason : s.reason + ": " + s.detail;
}

std::array<float, 3> gateDecisionColour(const std::string& reason) {
  using G = vadop::GateState;
  if (reason == G::REASON_CLEAR) return {0.1f, 0.8f, 0.1f};
  if (reason == G::REASON_SLOW) return {1.0f, 0.65f, 0.0f};
  if (reason == G::REASON_STOP) return {0.9f, 0.1f, 0.1f};
  if (reason == G::REASON_BAD_COMMAND) return {0.9f, 0.1f, 0.9f};
  return {0.6f, 0.6f, 0.6f};  // stale, timeout, or anything the gate could not check
}

visualization_msgs::Marker gateDecisionMarker(const vadop::GateState& state, const std::string& ns,
                                              const std::string& frame, const ros::Time& stamp,
                                              const Eigen::Vector3d& position) {
  Marker m;
  m.header.frame_id = frame;
  m.header.stamp = stamp;
  m.ns = ns;
  m.id = kGateDecisionId;
  m.action = Marker::ADD;
  m.type = Marker::TEXT_VIEW_FACING;
  m.pose.position = point(position);
  m.pose.orientation.w = 1.0;
  m.scale.z = kGateDecisionHeight;
  m.text = gateDecisionText(state);
  setColour(m, gateDecisionColour(state.reason), 1.0f);
  return m;
}

std::array<float, 3> impactColour(double soonest, double horizon) {
  if (soonest < kRedSeconds) return {0.9f, 0.1f, 0.1f};
  if (soonest <= horizon && std::isfinite(soonest)) return {1.0f, 0.65f, 0.0f};
  return {0.6f, 0.6f, 0.6f};
}

visualization_msgs::MarkerArray buildMarkers(const MarkerInput& in) {
  visualization_msgs::MarkerArray out;
  Marker clear;
  clear.header.frame_id = in.frame;
  clear.header.stamp = in.stamp;
  clear.action = Marker::DELETEALL;
  out.markers.push_back(clear);

  std::map<std::string, int> next_id;  // per namespace
  for (const MarkerElement& e : in.elements) addElementMarkers(out, in, e, next_id[e.body]);
  if (in.impacts) {
    int id = 0;
    for (const vadop::Impact& imp : in.impacts->impacts) addImpactMarkers(out, in, imp, id);
    addPairLabels(out, in, id);
  }
  return out;
}

}  // namespace vadop_ros
