// Compares two predictions up to what the narrow phase's contract leaves open (test helper).
//
// A contact's time is any t with gap(t) <= tol after a gap > tol / 2 (time_of_impact.h), so
// two correct searches of one pair started at different times (the whole window, or only the
// parts of it where the pair's boxes overlap) agree on the pair, not on the last digits: at
// closing speed v their times differ by about tol / v. With the default tol (1e-6 m) that is
// within kContactTime for every v above 0.1 m/s. Where parallel faces or edges meet, the
// contact is a patch and its point any point of it (the searches' last witnesses differ):
// points are compared along the normal, on which the patch's plane lies. Pairs, sections and
// the undecided pairs are compared exactly.
#pragma once

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <map>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace vadop::testing_compare {

constexpr double kContactTime = 1e-5;   // s
constexpr double kContactPoint = 1e-4;  // m along the normal (bodies here move at up to ~6 m/s)
constexpr double kNormal = 1e-3;        // |difference of the unit normals|

// Lines of impactsToJsonLines (and of undecided pairs), possibly split into sections by lines
// that are not JSON objects ("undecided:"): those must match exactly and in order; within a
// section, the same pairs with times, points and normals within the bounds above.
inline testing::AssertionResult sameImpactLines(const std::string& got, const std::string& want) {
  using Section = std::map<std::pair<std::string, std::string>, nlohmann::json>;
  auto parse = [](const std::string& text, std::vector<std::string>& headers, std::vector<Section>& sections) {
    sections.emplace_back();
    std::istringstream in(text);
    std::string line;
    while (std::getline(in, line)) {
      if (line.empty() || line[0] != '{') {
        headers.push_back(line);
        sections.emplace_back();
        continue;
      }
      const nlohmann::json j = nlohmann::json::parse(line);
      sections.back()[{j.at("a").get<std::string>(), j.at("b").get<std::string>()}] = j;
    }
  };
  std::vector<std::string> got_headers, want_headers;
  std::vector<Section> got_sections, want_sections;
  parse(got, got_headers, got_sections);
  parse(want, want_headers, want_sections);
  if (got_headers != want_headers) return testing::AssertionFailure() << "different sections";
  std::ostringstream why;
  int differences = 0;
  auto differ = [&](const std::string& what) {
    if (differences++ < 5) why << what << "\n";
  };
  for (size_t s = 0; s < got_sections.size(); ++s) {
    const Section& g = got_sections[s];
    const Section& w = want_sections[s];
    for (const auto& [pair, x] : w) {
      if (!g.count(pair)) differ("missing " + pair.first + " <-> " + pair.second + ": " + x.dump());
    }
    for (const auto& [pair, x] : g) {
      const auto it = w.find(pair);
      if (it == w.end()) {
        differ("extra " + pair.first + " <-> " + pair.second + ": " + x.dump());
        continue;
      }
      const nlohmann::json& y = it->second;
      double along = 0.0, dn = 0.0;
      for (int k = 0; k < 3; ++k) {
        along += (x.at("point")[k].get<double>() - y.at("point")[k].get<double>()) * y.at("normal")[k].get<double>();
        dn += std::pow(x.at("normal")[k].get<double>() - y.at("normal")[k].get<double>(), 2);
      }
      if (std::abs(x.at("time").get<double>() - y.at("time").get<double>()) > kContactTime ||
          std::abs(along) > kContactPoint || std::sqrt(dn) > kNormal) {
        differ("got " + x.dump() + "\n want " + y.dump());
      }
    }
  }
  if (differences == 0) return testing::AssertionSuccess();
  return testing::AssertionFailure() << differences << " difference(s):\n" << why.str();
}

}  // namespace vadop::testing_compare
