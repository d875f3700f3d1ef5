#include "vadop_ros/label_layout.h"

#include <cmath>

namespace vadop_ros {

LabelBox labelBox(const Eigen::Vector3d& centre, size_t chars, double height) {
  LabelBox box;
  box.centre = centre;
  box.width = static_cast<double>(chars) * kLabelCharWidth * height;
  box.height = height;
  return box;
}

bool labelsOverlap(const LabelBox& a, const LabelBox& b) {
  const Eigen::Vector3d d = (a.centre - b.centre).cwiseAbs();
  const double across = 0.5 * (a.width + b.width);
  return d.x() < across && d.y() < across && d.z() < 0.5 * (a.height + b.height);
}

std::vector<LabelBox> layoutLabels(const std::vector<Eigen::Vector3d>& anchors, const std::vector<std::string>& texts,
                                   double height, double raise) {
  std::vector<LabelBox> placed;
  placed.reserve(anchors.size());
  const double gap = kLabelGap * height;
  for (size_t k = 0; k < anchors.size() && k < texts.size(); ++k) {
    LabelBox box = labelBox(anchors[k] + Eigen::Vector3d(0.0, 0.0, raise), texts[k].size(), height);
    // Each move puts the box just above one placed box, so z only grows and every placed box
    // is passed at most once: at most placed.size() moves.
    for (bool moved = true; moved;) {
      moved = false;
      for (const LabelBox& other : placed) {
        if (!labelsOverlap(box, other)) continue;
        box.centre.z() = other.centre.z() + 0.5 * (other.height + box.height) + gap;
        moved = true;
      }
    }
    placed.push_back(box);
  }
  return placed;
}

}  // namespace vadop_ros
