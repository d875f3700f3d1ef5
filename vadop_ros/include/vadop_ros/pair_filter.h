// Which pairs of monitored elements are never reported: ~ignore_pairs (glob patterns on
// "body/link"), self-collisions of a body (~self_collision) and static-static pairs.
//
// Glob syntax: '*' matches any sequence of characters, '/' included; every other character
// matches itself (case-sensitive). A pattern is matched against "body/link", the configured
// body name and the URDF link name; for a primitive body (no link) against "body" and "body/",
// so "robot_1", "robot_*" and "robot_1/*" all match the primitive body robot_1, and
// "robot_1/*" matches every link of a URDF body robot_1. A pair [p, q] ignores the pairs
// (x, y) with p matching x and q matching y, or p matching y and q matching x.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace vadop_ros {

// Whole-string glob match ('*' = any sequence). Linear-time (greedy with backtracking to the
// last '*'), so a pattern cannot blow up on adversarial names.
bool globMatch(const std::string& pattern, const std::string& text);

// One element as the filter sees it.
struct ElementKey {
  std::string body;
  std::string link;  // empty for a primitive body
};

// Whether `pattern` matches the element (see above).
bool patternMatches(const std::string& pattern, const ElementKey& e);

class PairFilter {
 public:
  explicit PairFilter(std::vector<std::pair<std::string, std::string>> ignore_pairs = {})
      : patterns_(std::move(ignore_pairs)) {}

  // True when ~ignore_pairs ignores the pair (in either order).
  bool ignored(const ElementKey& a, const ElementKey& b) const;
  bool empty() const { return patterns_.empty(); }

  // The same test precomputed per element, for many pairs (no string work per pair): bit k of
  // `first` (`second`) is set when the first (second) pattern of pair k matches the element.
  // ignored(matches(a), matches(b)) == ignored(a, b).
  struct Matches {
    std::vector<uint64_t> first, second;  // ceil(pairs / 64) words each
  };
  Matches matches(const ElementKey& e) const;
  static bool ignored(const Matches& a, const Matches& b);

 private:
  std::vector<std::pair<std::string, std::string>> patterns_;
};

}  // namespace vadop_ros
