// Placement of rviz text labels so that they do not overlap, in world space (no camera).
//
// A label is a line of TEXT_VIEW_FACING text: rviz centres it on its position, its height is the
// marker's scale.z and its width is estimated as characters x kLabelCharWidth x height. As the
// text turns to face any camera, its horizontal footprint is taken as the square of side its
// width around its position (whatever the view's azimuth, the text stays inside it); its box is
// that footprint times [z - height / 2, z + height / 2].
// layoutLabels raises each label above its anchor and stacks, in a fixed order, the labels whose
// footprints intersect: a label whose footprint meets an earlier label's joins that label's
// column (takes its x and y: a stack at one place reads from every azimuth, while labels at
// different depths would slide over each other on screen), and goes just above every earlier
// one it would overlap, so no two boxes intersect. So a label stands above its anchor or, in a
// crowd, within a label's width of it. Deterministic: the result depends on the labels' order
// and values only.
// It does not move labels sideways, wrap text, or know what a camera sees (two labels far apart
// in the world can still meet on screen when one is behind the other; see kLabelGap for the
// views a stack reads from).
#pragma once

#include <Eigen/Core>

#include <string>
#include <vector>

namespace vadop_ros {

// Estimated width of one character of rviz's marker font, as a fraction of the text height
// (generous: capitals and digits are wider than the average letter).
constexpr double kLabelCharWidth = 0.6;
// Vertical space kept between two stacked labels, as a fraction of the text height. A camera
// looking down at pitch p sees a vertical step foreshortened by cos p while the text faces it at
// full height: a step of height / cos 60 deg (gap 1.0) keeps stacked labels apart on screen for
// views down to 60 deg (the shipped view looks down at 57 deg); 1.2 leaves a margin for
// perspective. From straight above, stacked labels cover each other.
constexpr double kLabelGap = 1.2;

struct LabelBox {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double width = 0.0;   // along x and y (the footprint's side)
  double height = 0.0;  // along z
};

// The box of a text of `chars` characters and height `height` centred at `centre`.
LabelBox labelBox(const Eigen::Vector3d& centre, size_t chars, double height);

// True when the two boxes' footprints (x, y) intersect; when the boxes intersect (touching is
// not intersecting).
bool footprintsOverlap(const LabelBox& a, const LabelBox& b);
bool labelsOverlap(const LabelBox& a, const LabelBox& b);

// Boxes for labels of the given texts anchored at `anchors` (same length), each `raise` above
// its anchor at least, stacked so that no two intersect; in the order given.
std::vector<LabelBox> layoutLabels(const std::vector<Eigen::Vector3d>& anchors, const std::vector<std::string>& texts,
                                   double height, double raise);

}  // namespace vadop_ros
