// ~ignore_pairs glob matching.
#include "vadop_ros/pair_filter.h"

#include <gtest/gtest.h>

using vadop_ros::ElementKey;
using vadop_ros::globMatch;
using vadop_ros::PairFilter;
using vadop_ros::patternMatches;

TEST(Glob, Basics) {
  EXPECT_TRUE(globMatch("abc", "abc"));
  EXPECT_FALSE(globMatch("abc", "abd"));
  EXPECT_FALSE(globMatch("abc", "abcd"));
  EXPECT_FALSE(globMatch("abcd", "abc"));
  EXPECT_TRUE(globMatch("*", ""));
  EXPECT_TRUE(globMatch("*", "anything/at/all"));
  EXPECT_TRUE(globMatch("a*", "a"));
  EXPECT_TRUE(globMatch("a*c", "abbbc"));
  EXPECT_FALSE(globMatch("a*c", "abbbd"));
  EXPECT_TRUE(globMatch("*c", "abc"));
  EXPECT_TRUE(globMatch("a**c", "ac"));
  EXPECT_TRUE(globMatch("robot_*/arm*", "robot_12/arm_link"));
  EXPECT_FALSE(globMatch("robot_*/arm*", "robot_12/base"));
  EXPECT_TRUE(globMatch("*/gripper*", "r1/gripper_left"));
  EXPECT_FALSE(globMatch("", "a"));
  EXPECT_TRUE(globMatch("", ""));
  EXPECT_FALSE(globMatch("ABC", "abc"));  // case-sensitive
  // Backtracking: the first '*' must give back characters.
  EXPECT_TRUE(globMatch("*ab*ab", "xxabyyabab"));
  EXPECT_FALSE(globMatch("*ab*ab", "xxabyyaba"));
}

TEST(Glob, LinearTimeOnAdversarialInput) {
  const std::string text(20000, 'a');
  const std::string pattern = "*a*a*a*a*a*a*a*a*b";
  EXPECT_FALSE(globMatch(pattern, text));  // must return promptly
}

TEST(Glob, ElementMatching) {
  const ElementKey primitive{"robot_1", ""};
  const ElementKey link{"robot_1", "mast"};
  EXPECT_TRUE(patternMatches("robot_1", primitive));
  EXPECT_TRUE(patternMatches("robot_*", primitive));
  EXPECT_TRUE(patternMatches("robot_1/*", primitive));
  EXPECT_FALSE(patternMatches("robot_1/mast", primitive));
  EXPECT_TRUE(patternMatches("robot_1/*", link));
  EXPECT_TRUE(patternMatches("robot_1/mast", link));
  EXPECT_TRUE(patternMatches("*/mast", link));
  EXPECT_TRUE(patternMatches("robot_*", link));  // '*' crosses '/'
  EXPECT_FALSE(patternMatches("robot_1", link));
  EXPECT_FALSE(patternMatches("robot_2/*", link));
}

TEST(PairFilter, EitherOrder) {
  const PairFilter f({{"robot_1/*", "shelf"}, {"*/gripper", "parcel_*"}});
  EXPECT_TRUE(f.ignored({"robot_1", "base"}, {"shelf", ""}));
  EXPECT_TRUE(f.ignored({"shelf", ""}, {"robot_1", "base"}));
  EXPECT_FALSE(f.ignored({"robot_2", "base"}, {"shelf", ""}));
  EXPECT_TRUE(f.ignored({"parcel_7", ""}, {"arm", "gripper"}));
  EXPECT_FALSE(f.ignored({"parcel_7", ""}, {"arm", "wrist"}));
  EXPECT_FALSE(f.ignored({"robot_1", "base"}, {"robot_1", "mast"}));
  EXPECT_FALSE(PairFilter().ignored({"a", ""}, {"b", ""}));
}
// Issue 14, item 5: the per-element bitsets (MonitorCore's filter before the narrow phase)
// agree with ignored() on every pair, with more than 64 pattern pairs (two words).
TEST(PairFilter, PrecomputedMatchesAgreeWithIgnored) {
  std::vector<std::pair<std::string, std::string>> pats = {{"a", "b*"}, {"robot_*/mast", "robot_1/*"}, {"*", "w"}};
  for (int k = 0; k < 70; ++k) pats.emplace_back("x" + std::to_string(k), "*/l" + std::to_string(k % 3));
  const vadop_ros::PairFilter f(pats);
  const std::vector<vadop_ros::ElementKey> es = {{"a", ""},       {"b", ""},          {"bb", "l1"}, {"robot_1", "mast"},
                                                 {"robot_2", "mast"}, {"robot_1", "base"}, {"w", ""},    {"x69", ""},
                                                 {"y", "l0"},     {"y", "l2"},        {"z", ""}};
  std::vector<vadop_ros::PairFilter::Matches> ms;
  for (const auto& e : es) ms.push_back(f.matches(e));
  size_t ignored = 0;
  for (size_t i = 0; i < es.size(); ++i) {
    for (size_t j = 0; j < es.size(); ++j) {
      EXPECT_EQ(vadop_ros::PairFilter::ignored(ms[i], ms[j]), f.ignored(es[i], es[j])) << i << " " << j;
      ignored += f.ignored(es[i], es[j]);
    }
  }
  EXPECT_GT(ignored, 0u);
  EXPECT_LT(ignored, es.size() * es.size());
  // x69 (pattern pair 72, second word) with y/l0 (69 % 3 = 0).
  EXPECT_TRUE(vadop_ros::PairFilter::ignored(ms[7], ms[8]));
  EXPECT_FALSE(vadop_ros::PairFilter::ignored(ms[7], ms[9]));
}

// The one matching of an element against a glob list (~ignore_pairs' sides, a gate's ignore):
// bit k for globs[k], over more than one word.
TEST(Glob, MatchingGlobsSetsOneBitPerMatchingGlob) {
  std::vector<std::string> globs = {"robot_1/*", "shelf", "*/mast"};
  for (int k = 0; k < 64; ++k) globs.push_back("x" + std::to_string(k));
  globs.push_back("robot_*");  // k = 67: the second word
  const vadop_ros::GlobBits bits = vadop_ros::matchingGlobs(globs, {"robot_1", "mast"});
  ASSERT_EQ(bits.size(), 2u);
  EXPECT_EQ(bits[0], (uint64_t{1} << 0) | (uint64_t{1} << 2));
  EXPECT_EQ(bits[1], uint64_t{1} << 3);
  EXPECT_TRUE(vadop_ros::anyMatched(bits));
  EXPECT_FALSE(vadop_ros::anyMatched(vadop_ros::matchingGlobs(globs, {"shelves", ""})));
  EXPECT_EQ(vadop_ros::matchingGlobs(globs, {"x60", ""})[0], uint64_t{1} << 63);  // globs[63]
  EXPECT_TRUE(vadop_ros::matchingGlobs({}, {"a", ""}).empty());
  EXPECT_FALSE(vadop_ros::anyMatched(vadop_ros::matchingGlobs({}, {"a", ""})));
}
