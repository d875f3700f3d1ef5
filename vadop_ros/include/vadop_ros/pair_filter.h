// How the node matches its elements against glob lists: the patterns of ~ignore_pairs
// (PairFilter, one list per side of the pairs) and a gate's ignore list (GateParams::ignore)
// both go through matchingGlobs. The rule of which pairs are tested (these globs, the
// self-collisions of a body, static-static pairs) is MonitorCore::pairIgnored's; this file
// only matches names.
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

// Which of `globs` match the element (patternMatches): bit k % 64 of word k / 64 set when
// globs[k] does (ceil(globs.size() / 64) words). Matched once per element, so that a rule
// asked for many pairs or queries does no string work (PairFilter::matches, a gate's ignore).
using GlobBits = std::vector<uint64_t>;
GlobBits matchingGlobs(const std::vector<std::string>& globs, const ElementKey& e);
// Some glob matched.
bool anyMatched(const GlobBits& bits);

class PairFilter {
 public:
  explicit PairFilter(std::vector<std::pair<std::string, std::string>> ignore_pairs = {});

  // True when ~ignore_pairs ignores the pair (in either order).
  bool ignored(const ElementKey& a, const ElementKey& b) const;
  bool empty() const { return patterns_.empty(); }

  // The same test precomputed per element, for many pairs (no string work per pair): bit k of
  // `first` (`second`) is set when the first (second) pattern of pair k matches the element.
  // ignored(matches(a), matches(b)) == ignored(a, b).
  struct Matches {
    GlobBits first, second;  // matchingGlobs of the pairs' first (second) patterns
  };
  Matches matches(const ElementKey& e) const;
  static bool ignored(const Matches& a, const Matches& b);

 private:
  std::vector<std::pair<std::string, std::string>> patterns_;
  std::vector<std::string> firsts_, seconds_;  // the pairs' sides, in order
};

}  // namespace vadop_ros
