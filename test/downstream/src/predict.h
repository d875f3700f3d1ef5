// The library side of the check, in a translation unit of its own: vadop_core's vadop::Impact
// (vadop/time_of_impact.h, included by vadop/world.h) and the message vadop::Impact generated
// for the package vadop (msg/Impact.msg) are two types of the same name, so no translation unit
// may include both (vadop_ros does the same: vadop_ros/predictor.h).
#pragma once

#include <string>
#include <vector>

struct PlainImpact {
  std::string a, b;
  double time = 0.0;
  double point[3] = {0, 0, 0};
  double normal[3] = {0, 0, 0};
  bool initially_touching = false;
};

// A vadop::World with two spheres on a head-on course, predicted over [0, 2] s.
std::vector<PlainImpact> predictHeadOn();
