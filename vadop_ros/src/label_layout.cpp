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

bool footprintsOverlap(const LabelBox& a, const LabelBox& b) {
  const double across = 0.5 * (a.width + b.width);
  return std::abs(a.centre.x() - b.centre.x()) < across && std::abs(a.centre.y() - b.centre.y()) < across;
}

bool labelsOverlap(const LabelBox& a, const LabelBox& b) {
  return footprintsOverlap(a, b) && std::abs(a.centre.z() - b.centre.z()) < 0.5 * (a.height + b.height);
}

std::vector<LabelBox> layoutLabels(const std::vector<Eigen::Vector3d>& anchors, const std::vector<std::string>& texts,
                                   double height, double raise) {
  std::vector<LabelBox> placed;
  placed.reserve(anchors.size());
  const double gap = kLabelGap * height;
  for (size_t k = 0; k < anchors.size() && k < texts.size(); ++k) {
    LabelBox box = labelBox(anchors[k] + Eigen::Vector3d(0.0, 0.0, raise), texts[k].size(), height);
    // Near an earlier label: in its column (same x, y), so that the stack's steps are purely
    // vertical; labels at different depths would slide over each other on screen.
    for (const LabelBox& other : placed) {
      if (footprintsOverlap(box, other)) {
        box.centre.x() = other.centre.x();
        box.centre.y() = other.centre.y();
        break;
      }
    }
    // Each move puts the box just above one placed box, so z only grows and every placed box
    // is passed at most once: at most placed.size() moves.
    for (bool moved = true; moved;) {
      moved = false;
      for (const LabelBox& other : placed) {
        // (Less a rounding slack: a box just put above `other` must not count as too close.)
        const double step = 0.5 * (box.height + other.height) + gap;
        const bool too_close =
            footprintsOverlap(box, other) && std::abs(box.centre.z() - other.centre.z()) < step * (1.0 - 1e-9);
        if (!too_close) continue;
        box.centre.z() = other.centre.z() + step;
        moved = true;
      }
    }
    placed.push_back(box);
  }
  return placed;
}

}  // namespace vadop_ros
