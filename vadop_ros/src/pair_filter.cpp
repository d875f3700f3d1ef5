#include "vadop_ros/pair_filter.h"

#include <algorithm>

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

GlobBits matchingGlobs(const std::vector<std::string>& globs, const ElementKey& e) {
  GlobBits bits((globs.size() + 63) / 64, 0);
  for (size_t k = 0; k < globs.size(); ++k) {
    if (patternMatches(globs[k], e)) bits[k / 64] |= uint64_t{1} << (k % 64);
  }
  return bits;
}

bool anyMatched(const GlobBits& bits) {
  return std::any_of(bits.begin(), bits.end(), [](uint64_t w) { return w != 0; });
}

PairFilter::PairFilter(std::vector<std::pair<std::string, std::string>> ignore_pairs)
    : patterns_(std::move(ignore_pairs)) {
  for (const auto& pq : patterns_) {
    firsts_.push_back(pq.first);
    seconds_.push_back(pq.second);
  }
}

bool PairFilter::ignored(const ElementKey& a, const ElementKey& b) const {
  for (const auto& pq : patterns_) {
    if (patternMatches(pq.first, a) && patternMatches(pq.second, b)) return true;
    if (patternMatches(pq.first, b) && patternMatches(pq.second, a)) return true;
  }
  return false;
}

PairFilter::Matches PairFilter::matches(const ElementKey& e) const {
  return Matches{matchingGlobs(firsts_, e), matchingGlobs(seconds_, e)};
}

bool PairFilter::ignored(const Matches& a, const Matches& b) {
  const size_t words = std::min(a.first.size(), b.first.size());
  for (size_t w = 0; w < words; ++w) {
    if ((a.first[w] & b.second[w]) | (b.first[w] & a.second[w])) return true;
  }
  return false;
}

}  // namespace vadop_ros
