// rviz markers of one monitor cycle (~markers, visualization_msgs/MarkerArray).
//
// Swept volume representation: for every element of a moving body, its shape at the start
// pose (now) and, fainter, at the end pose (now + horizon), joined by a line strip along the
// path of its origin (sampled, so a turning body draws an arc). An element on a planned path
// (MarkerElement::path) is also drawn, faint, at each pose of the path inside the horizon (at
// most kPathGhosts of them, evenly picked), and its line follows the path. Static obstacles:
// the shape only. Meshes are drawn as MESH_RESOURCE from their URI (without the padding); a mesh
// without one (a sensor's points or a map's cells) as one SPHERE_LIST of its points (balls of
// its margin: point radius and padding) or one TRIANGLE_LIST of its faces; the other
// shapes include the padding (boxes and cylinders as their padded bounding primitive).
// Colour: by the body's soonest time to impact: red below 0.5 s, amber below the horizon,
// grey when clear.
// Impacts (namespace "impacts"): a sphere at each contact point and an arrow along its normal
// (from a to b); and one text a body pair, "a/link <-> b/link: 0.83 s" of the pair's soonest
// impact, above its point (in a crowd: stacked in a nearby label's column) so that no two labels
// overlap (label_layout.h).
// A gate's decision (gateDecisionMarker): a text above the gated body in the gate's namespace,
// "stop: r2 in 0.80 s", "slow 40%: r2/arm in 1.30 s", "clear", "stale: <detail>",
// "timeout: <detail>", "bad_command: <detail>"; green when clear, amber when slow, red when
// stopped, grey when stale or timed out, magenta for a bad command.
// Namespaces: one per body (its name), plus "impacts". The array always starts with a
// DELETEALL marker, so nothing from an earlier cycle lingers.
#pragma once

#include <vadop/GateState.h>
#include <vadop/ImpactArray.h>
#include <vadop/motion.h>
#include <vadop/shapes.h>

#include <visualization_msgs/MarkerArray.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <array>
#include <functional>

#include <string>
#include <vector>

namespace vadop_ros {

struct MarkerElement {
  std::string body;
  std::string link;
  bool is_static = false;
  vadop::Shape shape;  // padded, as in the world
  vadop::Motion motion;
  // An element on a planned path: its pose at a time (empty: motion's) and the times of the
  // path's poses. (This header cannot see vadop::TimedPath: the message's vadop::Impact would
  // clash with the library's.)
  std::function<Eigen::Isometry3d(double)> path_pose;
  std::vector<double> path_times;
  std::string mesh_uri;
  Eigen::Vector3d mesh_scale = Eigen::Vector3d::Ones();
  double soonest = 0.0;  // the body's soonest time to impact (s), +inf when clear
};

struct MarkerInput {
  std::string frame;
  ros::Time stamp;
  double t0 = 0.0;       // the cycle time in the motions' time base
  double horizon = 2.0;
  std::vector<MarkerElement> elements;
  const vadop::ImpactArray* impacts = nullptr;
};

// Most intermediate poses drawn for an element on a planned path.
constexpr int kPathGhosts = 8;

// Time to impact below which a body is drawn red.
constexpr double kRedSeconds = 0.5;

// A body pair's label: text height and how far above the impact point it starts (m).
constexpr double kLabelHeight = 0.18;
constexpr double kLabelRaise = 0.35;

visualization_msgs::MarkerArray buildMarkers(const MarkerInput& input);

// The label of an impact's pair: "a/link <-> b/link: 0.83 s".
std::string pairLabel(const vadop::Impact& imp);

// The colour rule above (r, g, b, a = 1).
std::array<float, 3> impactColour(double soonest, double horizon);

// The id of a gate's decision text in its namespace (above the ids of its swept volume).
constexpr int kGateDecisionId = 1 << 20;
// How far above the gated body's top its decision is drawn (m), and the text's height.
constexpr double kGateDecisionRaise = 0.4;
constexpr double kGateDecisionHeight = 0.25;

// The text and colour of a gate's decision (the rule above).
std::string gateDecisionText(const vadop::GateState& state);
std::array<float, 3> gateDecisionColour(const std::string& reason);
// The decision's TEXT_VIEW_FACING marker (id kGateDecisionId) at `position`.
visualization_msgs::Marker gateDecisionMarker(const vadop::GateState& state, const std::string& ns,
                                              const std::string& frame, const ros::Time& stamp,
                                              const Eigen::Vector3d& position);

}  // namespace vadop_ros
