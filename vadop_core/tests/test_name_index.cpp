// NameIndex against std::unordered_map over the same random sequences of inserts, erases and
// lookups: after every step each name of the pool is found exactly when the map has it, under
// the same id, and forEach lists exactly the map's ids. Small tables (many names per probe run,
// runs wrapping around the end) and growth through reserve().
#include "name_index.h"  // internal (vadop_core/src)

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <string>
#include <unordered_map>
#include <vector>

namespace vadop {
namespace {

using detail::NameIndex;

struct Fixture {
  std::vector<std::string> names_by_id;  // what a World keeps in its records
  NameIndex index;
  std::unordered_map<std::string, uint32_t> reference;

  const std::string& nameOf(uint32_t id) const { return names_by_id.at(id); }
  uint32_t find(const std::string& name) const {
    return index.find(name, [this](uint32_t id) -> const std::string& { return nameOf(id); });
  }
  void insert(const std::string& name) {
    const uint32_t id = static_cast<uint32_t>(names_by_id.size());
    names_by_id.push_back(name);
    index.reserve(index.size() + 1);
    index.insert(name, id);
    reference.emplace(name, id);
  }
  void erase(const std::string& name) {
    index.erase(name, [this](uint32_t id) -> const std::string& { return nameOf(id); });
    reference.erase(name);
  }
  void check(const std::vector<std::string>& pool, const char* step) const {
    ASSERT_EQ(index.size(), reference.size()) << step;
    for (const std::string& name : pool) {
      const auto it = reference.find(name);
      const uint32_t want = it == reference.end() ? NameIndex::kNone : it->second;
      ASSERT_EQ(find(name), want) << step << ": " << name;
    }
    std::vector<uint32_t> listed, expected;
    index.forEach([&](uint32_t id) { listed.push_back(id); });
    for (const auto& kv : reference) expected.push_back(kv.second);
    std::sort(listed.begin(), listed.end());
    std::sort(expected.begin(), expected.end());
    ASSERT_EQ(listed, expected) << step;
  }
};

TEST(NameIndex, AgreesWithAHashMapOverRandomInsertsAndErases) {
  std::mt19937 rng(7);
  for (int round = 0; round < 40; ++round) {
    // Pools of 6 to 60 names: the table stays at 16 to 128 slots, so probe runs are long,
    // wrap around its end, and erases shift entries back across the wrap.
    const int pool_size = 6 + static_cast<int>(rng() % 55);
    std::vector<std::string> pool;
    for (int i = 0; i < pool_size; ++i) pool.push_back("robot_" + std::to_string(round) + "/link" + std::to_string(i));
    pool.push_back("");  // never inserted: looked up like any other
    Fixture f;
    f.check(pool, "empty");
    for (int step = 0; step < 400; ++step) {
      const std::string& name = pool[rng() % (pool.size() - 1)];
      if (rng() % 3 != 0) {
        if (!f.reference.count(name)) f.insert(name);
      } else {
        f.erase(name);  // listed or not
      }
      f.check(pool, "after a step");
      if (::testing::Test::HasFatalFailure()) return;
    }
  }
}

TEST(NameIndex, KeepsEveryNameThroughGrowthAndMassErase) {
  Fixture f;
  std::vector<std::string> pool;
  for (int i = 0; i < 5000; ++i) pool.push_back("b" + std::to_string(i));
  for (const std::string& name : pool) f.insert(name);  // reserve() one at a time: many rehashes
  f.check(pool, "after 5000 inserts");
  for (size_t i = 0; i < pool.size(); i += 2) f.erase(pool[i]);
  f.check(pool, "after erasing every other name");
  for (size_t i = 0; i < pool.size(); i += 2) f.insert(pool[i]);  // back under new ids
  f.check(pool, "after inserting them again");
  for (const std::string& name : pool) f.erase(name);
  f.check(pool, "after erasing all");
  f.erase("b1");  // erasing from an empty (but allocated) table
  f.check(pool, "after erasing an absent name");
}

TEST(NameIndex, AnEmptyIndexFindsNothing) {
  NameIndex index;
  EXPECT_EQ(index.size(), 0u);
  EXPECT_EQ(index.find("x", [](uint32_t) -> const std::string& { throw std::logic_error("no names"); }),
            NameIndex::kNone);
  index.erase("x", [](uint32_t) -> const std::string& { throw std::logic_error("no names"); });
  EXPECT_EQ(index.size(), 0u);
}

}  // namespace
}  // namespace vadop
