#include "vadop_ros/pair_filter.h"

namespace vadop_ros {

bool globMatch(const std::string& pattern, const std::string& text) {
  size_t p = 0, t = 0;
  size_t star = std::string::npos, star_t = 0;
  while (t < text.size()) {
    if (p < pattern.size() && pattern[p] == '*') {
      star = p++;
      star_t = t;
    } else if (p < pattern.size() && pattern[p] == text[t]) {
      ++p;
      ++t;
    } else if (star != std::string::npos) {
      p = star + 1;
      t = ++star_t;
    } else {
      return false;
    }
  }
  while (p < pattern.size() && pattern[p] == '*') ++p;
  return p == pattern.size();
}

bool patternMatches(const std::string& pattern, const ElementKey& e) {
  if (e.link.empty()) return globMatch(pattern, e.body) || globMatch(pattern, e.body + "/");
  return globMatch(pattern, e.body + "/" + e.link);
}

bool PairFilter::ignored(const ElementKey& a, const ElementKey& b) const {
  for (const auto& pq : patterns_) {
    if (patternMatches(pq.first, a) && patternMatches(pq.second, b)) return true;
    if (patternMatches(pq.first, b) && patternMatches(pq.second, a)) return true;
  }
  return false;
}

}  // namespace vadop_ros
