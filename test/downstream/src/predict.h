// The library side of the check: vadop_core's World predicts, and the result is given back as
// plain data. (The library's types no longer share a name with the package's messages: the
// narrow phase's result is vadop::TimeOfImpact; use_vadop.cpp includes both headers.)
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
