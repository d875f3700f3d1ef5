// The markers' labels (markers.h, label_layout.h): one label per body pair, none overlapping
// another on a crowded scene; a gate decision's text and colour per reason.
#include "vadop_ros/label_layout.h"
#include "vadop_ros/markers.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <set>
#include <string>
#include <vector>

namespace {

using visualization_msgs::Marker;

vadop::Impact impact(const std::string& a, const std::string& la, const std::string& b, const std::string& lb,
                     double t, double x, double y, double z) {
  vadop::Impact imp;
  imp.body_a = a;
  imp.link_a = la;
  imp.body_b = b;
  imp.link_b = lb;
  imp.time_to_impact = t;
  imp.point.x = x;
  imp.point.y = y;
  imp.point.z = z;
  imp.normal.x = 1.0;
  return imp;
}

std::string name(const std::string& body, const std::string& link) {
  return link.empty() ? body : body + "/" + link;
}

// Many bodies with links, every impact within a 1.5 m x 1.5 m square and 0.3 m of height,
// several impacts per pair (each link pair, either order).
vadop::ImpactArray crowdedScene(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> xy(-0.75, 0.75), z(0.0, 0.3), t(0.0, 2.0);
  vadop::ImpactArray out;
  const int bodies = 9;
  for (int a = 0; a < bodies; ++a) {
    for (int b = a + 1; b < bodies; ++b) {
      if ((a + b + seed) % 3 == 0) continue;  // not every pair
      for (int k = 0; k < 3; ++k) {
        const std::string ba = "r" + std::to_string(a), bb = "r" + std::to_string(b);
        const std::string la = k == 2 ? "" : "arm" + std::to_string(k), lb = "link_" + std::to_string(k);
        if (k == 1) {
          out.impacts.push_back(impact(bb, lb, ba, la, t(rng), xy(rng), xy(rng), z(rng)));
        } else {
          out.impacts.push_back(impact(ba, la, bb, lb, t(rng), xy(rng), xy(rng), z(rng)));
        }
      }
    }
  }
  return out;
}

struct Box {
  double x, y, z, half_w, half_h;
};

// The text's box as the test estimates it from the marker alone: centred on its position,
// width characters x kLabelCharWidth x height in x and y, height scale.z.
Box boxOf(const Marker& m) {
  const double w = static_cast<double>(m.text.size()) * vadop_ros::kLabelCharWidth * m.scale.z;
  return {m.pose.position.x, m.pose.position.y, m.pose.position.z, 0.5 * w, 0.5 * m.scale.z};
}

bool intersect(const Box& a, const Box& b) {
  return std::abs(a.x - b.x) < a.half_w + b.half_w && std::abs(a.y - b.y) < a.half_w + b.half_w &&
         std::abs(a.z - b.z) < a.half_h + b.half_h;
}

std::vector<Marker> labels(const visualization_msgs::MarkerArray& array) {
  std::vector<Marker> out;
  for (const Marker& m : array.markers) {
    if (m.ns == "impacts" && m.type == Marker::TEXT_VIEW_FACING) out.push_back(m);
  }
  return out;
}

TEST(Markers, OneLabelPerBodyPairAndNoTwoLabelsOverlapOnACrowdedScene) {
  for (unsigned seed = 1; seed <= 5; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const vadop::ImpactArray impacts = crowdedScene(seed);
    vadop_ros::MarkerInput in;
    in.frame = "odom";
    in.impacts = &impacts;
    const std::vector<Marker> got = labels(vadop_ros::buildMarkers(in));

    // Brute force: each unordered body pair's soonest impact and its expected text.
    std::map<std::pair<std::string, std::string>, const vadop::Impact*> soonest;
    for (const vadop::Impact& imp : impacts.impacts) {
      const auto key = std::minmax(imp.body_a, imp.body_b);
      const vadop::Impact*& s = soonest[{key.first, key.second}];
      if (!s || imp.time_to_impact < s->time_to_impact) s = &imp;
    }
    ASSERT_GT(soonest.size(), 15u);
    ASSERT_EQ(got.size(), soonest.size());
    std::map<std::string, const vadop::Impact*> expected;
    for (const auto& kv : soonest) {
      char secs[32];
      std::snprintf(secs, sizeof secs, ": %.2f s", kv.second->time_to_impact);
      const vadop::Impact& i = *kv.second;
      expected[name(i.body_a, i.link_a) + " <-> " + name(i.body_b, i.link_b) + secs] = &i;
    }
    std::set<std::string> seen;
    for (const Marker& m : got) {
      ASSERT_TRUE(expected.count(m.text)) << "unexpected label " << m.text;
      EXPECT_TRUE(seen.insert(m.text).second) << "label twice: " << m.text;
      const vadop::Impact& i = *expected[m.text];
      // Above its pair's soonest impact point, within a label's width of it sideways.
      EXPECT_LT(std::abs(m.pose.position.x - i.point.x), 2.0 * boxOf(m).half_w + 1.5);
      EXPECT_LT(std::abs(m.pose.position.y - i.point.y), 2.0 * boxOf(m).half_w + 1.5);
      EXPECT_GE(m.pose.position.z, i.point.z + vadop_ros::kLabelRaise - 1e-12);
    }
    int overlaps = 0;
    for (size_t a = 0; a < got.size(); ++a) {
      for (size_t b = a + 1; b < got.size(); ++b) {
        // Labels one above the other stand in one column, a step of at least height / cos 60 deg
        // apart: apart on screen for cameras looking down at up to 60 deg.
        const Box ba = boxOf(got[a]), bb = boxOf(got[b]);
        if (std::abs(ba.x - bb.x) < ba.half_w + bb.half_w && std::abs(ba.y - bb.y) < ba.half_w + bb.half_w) {
          EXPECT_EQ(ba.x, bb.x);
          EXPECT_EQ(ba.y, bb.y);
          EXPECT_GE(std::abs(ba.z - bb.z), (ba.half_h + bb.half_h) / std::cos(M_PI / 3.0) - 1e-9);
        }
        if (intersect(boxOf(got[a]), boxOf(got[b]))) {
          ++overlaps;
          ADD_FAILURE() << "\"" << got[a].text << "\" overlaps \"" << got[b].text << "\"";
        }
        EXPECT_NE(got[a].id, got[b].id);
      }
    }
    EXPECT_EQ(overlaps, 0);
    // Deterministic: the same impacts, the same labels.
    const std::vector<Marker> again = labels(vadop_ros::buildMarkers(in));
    ASSERT_EQ(again.size(), got.size());
    for (size_t k = 0; k < got.size(); ++k) {
      EXPECT_EQ(again[k].text, got[k].text);
      EXPECT_EQ(again[k].pose.position.z, got[k].pose.position.z);
    }
  }
}

TEST(Markers, LabelsFarApartStayAtTheirAnchors) {
  vadop::ImpactArray impacts;
  impacts.impacts.push_back(impact("a", "", "b", "", 0.5, 0.0, 0.0, 1.0));
  impacts.impacts.push_back(impact("c", "", "d", "", 0.7, 10.0, 0.0, 1.0));
  vadop_ros::MarkerInput in;
  in.impacts = &impacts;
  const std::vector<Marker> got = labels(vadop_ros::buildMarkers(in));
  ASSERT_EQ(got.size(), 2u);
  for (const Marker& m : got) EXPECT_DOUBLE_EQ(m.pose.position.z, 1.0 + vadop_ros::kLabelRaise);
  EXPECT_EQ(got[0].text, "a <-> b: 0.50 s");
}

vadop::GateState gate(const std::string& reason, double scale, const std::string& body, const std::string& link,
                      double t, const std::string& detail = "") {
  vadop::GateState s;
  s.body = "r1";
  s.reason = reason;
  s.scale = scale;
  s.limiting_body = body;
  s.limiting_link = link;
  s.time_to_contact = t;
  s.detail = detail;
  return s;
}

TEST(Markers, GateDecisionTextAndColourPerReason) {
  using G = vadop::GateState;
  const double inf = std::numeric_limits<double>::infinity();
  struct Case {
    vadop::GateState state;
    std::string text;
    std::array<float, 3> colour;
  };
  const std::array<float, 3> green{0.1f, 0.8f, 0.1f}, amber{1.0f, 0.65f, 0.0f}, red{0.9f, 0.1f, 0.1f},
      grey{0.6f, 0.6f, 0.6f}, magenta{0.9f, 0.1f, 0.9f};
  const std::vector<Case> cases = {
      {gate(G::REASON_STOP, 0.0, "r2", "", 0.8), "stop: r2 in 0.80 s", red},
      {gate(G::REASON_STOP, 0.0, "", "", inf), "stop", red},
      {gate(G::REASON_SLOW, 0.4, "r2", "arm", 1.3), "slow 40%: r2/arm in 1.30 s", amber},
      {gate(G::REASON_CLEAR, 1.0, "", "", inf), "clear", green},
      {gate(G::REASON_CLEAR, 1.0, "r3", "", 0.4), "clear", green},
      {gate(G::REASON_STALE, 0.0, "", "", inf, "no command yet"), "stale: no command yet", grey},
      {gate(G::REASON_TIMEOUT, 0.0, "", "", inf, "no command for 0.5 s"), "timeout: no command for 0.5 s", grey},
      {gate(G::REASON_BAD_COMMAND, 0.0, "", "", inf, "NaN in linear.x"), "bad_command: NaN in linear.x", magenta},
  };
  for (const Case& c : cases) {
    const Marker m = vadop_ros::gateDecisionMarker(c.state, "gate/r1", "odom", ros::Time(2.0),
                                                   Eigen::Vector3d(1.0, 2.0, 3.0));
    EXPECT_EQ(m.text, c.text);
    EXPECT_EQ(m.type, Marker::TEXT_VIEW_FACING);
    EXPECT_EQ(m.ns, "gate/r1");
    EXPECT_EQ(m.header.frame_id, "odom");
    EXPECT_DOUBLE_EQ(m.pose.position.z, 3.0);
    EXPECT_FLOAT_EQ(m.color.r, c.colour[0]) << c.text;
    EXPECT_FLOAT_EQ(m.color.g, c.colour[1]) << c.text;
    EXPECT_FLOAT_EQ(m.color.b, c.colour[2]) << c.text;
    EXPECT_FLOAT_EQ(m.color.a, 1.0f);
  }
}

}  // namespace
