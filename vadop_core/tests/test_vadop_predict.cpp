// vadop_predict, the command-line tool, run as a process (VADOP_PREDICT_BIN):
//  - a small analytic scene whose output lines are computed by hand;
//  - --broadphase vadop|vadop_sap|sap|brute print byte-identical output on random 1,000-body scenes
//    (and the same as the World API);
//  - bad input or options: exit status 2, a one-line message naming body and field on stderr,
//    nothing on stdout; --help: usage, exit 0.
#include "vadop/scene_io.h"
#include "vadop/world.h"

#include "world_scene_gen.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <stdexcept>
#include <utility>
#include <sstream>
#include <string>
#include <vector>

#ifndef VADOP_PREDICT_BIN
#error "VADOP_PREDICT_BIN (the path of vadop_predict) must be defined by the build"
#endif

namespace vadop {
namespace {

class TempDir {
 public:
  TempDir() {
    char tmpl[] = "/tmp/vadop_predict_test_XXXXXX";
    const char* d = mkdtemp(tmpl);
    if (!d) throw std::runtime_error("mkdtemp failed");
    path_ = d;
  }
  ~TempDir() {
    for (const auto& f : files_) std::remove(f.c_str());
    rmdir(path_.c_str());
  }
  std::string file(const std::string& name, const std::string& content = "") {
    const std::string p = path_ + "/" + name;
    std::ofstream(p, std::ios::binary) << content;
    files_.push_back(p);
    return p;
  }

 private:
  std::string path_;
  std::vector<std::string> files_;
};

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string shellQuote(const std::string& s) {
  std::string out = "'";
  for (char c : s) {
    if (c == '\'') out += "'\\''";
    else out += c;
  }
  return out + "'";
}

struct ToolRun {
  int status = -1;
  std::string out, err;
};

// Runs vadop_predict with `args` (already shell-quoted where needed), stdin from `input_file`.
ToolRun run(const std::string& args, const std::string& input_file = "/dev/null") {
  TempDir dir;
  const std::string out = dir.file("stdout"), err = dir.file("stderr");
  const std::string cmd = shellQuote(VADOP_PREDICT_BIN) + " " + args + " < " + shellQuote(input_file) + " > " +
                          shellQuote(out) + " 2> " + shellQuote(err);
  const int raw = std::system(cmd.c_str());
  ToolRun r;
  r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : 128 + WTERMSIG(raw);
  r.out = slurp(out);
  r.err = slurp(err);
  return r;
}

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

TEST(VadopPredict, HeadOnSpheresAndTouchingPairsComputedByHand) {
  TempDir dir;
  // left/right: radius 0.5, centres 3 m apart closing at 2 m/s: they touch at t = 1 s at x = 1.5.
  // hub touches zeta (centres 1.5 apart along x, radii 1) and beta (1.5 apart along y) at t = 0.
  const std::string scene = dir.file("scene.json", R"({"horizon": 2.0, "bodies": [
    {"id": "left", "shape": {"type": "sphere", "radius": 0.5}, "position": [0, 0, 0], "linear_velocity": [1, 0, 0]},
    {"id": "right", "shape": {"type": "sphere", "radius": 0.5}, "position": [3, 0, 0], "linear_velocity": [-1, 0, 0]},
    {"id": "hub", "shape": {"type": "sphere", "radius": 1}, "position": [10, 0, 0]},
    {"id": "zeta", "shape": {"type": "sphere", "radius": 1}, "position": [11.5, 0, 0]},
    {"id": "beta", "shape": {"type": "sphere", "radius": 1}, "position": [10, 1.5, 0]},
    {"id": "far", "shape": {"type": "box", "size": [1, 1, 1]}, "position": [0, 100, 0], "linear_velocity": [0, 1, 0]}
  ]})");
  const ToolRun r = run(shellQuote(scene));
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.err, "");
  const auto out = lines(r.out);
  ASSERT_EQ(out.size(), 3u) << r.out;
  // Ties at t = 0 in input order (zeta before beta, although "beta" < "zeta"); the contact
  // point lies midway between the two surfaces; the normal points from a to b.
  EXPECT_EQ(out[0], R"({"a":"hub","b":"zeta","time":0.0,"point":[10.75,0.0,0.0],"normal":[1.0,0.0,0.0]})");
  EXPECT_EQ(out[1], R"({"a":"hub","b":"beta","time":0.0,"point":[10.0,0.75,0.0],"normal":[0.0,1.0,0.0]})");
  // The narrow phase reports the impact when the gap reaches tolerance / 2 = 5e-7 m, i.e.
  // 2.5e-7 s before the exact contact at t = 1 for a closing speed of 2 m/s.
  const auto j = nlohmann::json::parse(out[2]);
  EXPECT_EQ(j["a"], "left");
  EXPECT_EQ(j["b"], "right");
  EXPECT_NEAR(j["time"].get<double>(), 1.0 - 2.5e-7, 1e-12);
  EXPECT_NEAR(j["point"][0].get<double>(), 1.5, 1e-12);
  EXPECT_EQ(j["point"][1].get<double>(), 0.0);
  EXPECT_EQ(j["point"][2].get<double>(), 0.0);
  EXPECT_EQ(j["normal"], nlohmann::json::parse("[1.0, 0.0, 0.0]"));
  EXPECT_EQ(out[2].rfind(R"({"a":"left","b":"right","time":0.99999975)", 0), 0u) << out[2];

  // The same from standard input, with "-" and with no file argument.
  const ToolRun dash = run("-", scene);
  EXPECT_EQ(dash.status, 0);
  EXPECT_EQ(dash.out, r.out);
  const ToolRun none = run("", scene);
  EXPECT_EQ(none.status, 0);
  EXPECT_EQ(none.out, r.out);
  // A horizon that ends before the head-on contact: only the pairs touching at 0.
  auto half = nlohmann::json::parse(slurp(scene));
  half["horizon"] = 0.5;
  const std::string shorter = dir.file("short.json", half.dump());
  const ToolRun early = run(shellQuote(shorter));
  EXPECT_EQ(early.status, 0);
  EXPECT_EQ(lines(early.out), std::vector<std::string>(out.begin(), out.begin() + 2));
}

TEST(VadopPredict, BroadPhasesPrintByteIdenticalOutputOnRandomScenes) {
  TempDir dir;
  size_t total = 0;
  for (uint64_t seed = 1; seed <= 3; ++seed) {
    const std::string text = testing_scene::randomSceneJson(100 + seed);
    const std::string scene = dir.file("scene" + std::to_string(seed) + ".json", text);
    const ToolRun vadop = run(shellQuote(scene) + " --broadphase vadop");
    const ToolRun sap = run("--broadphase sap " + shellQuote(scene));
    const ToolRun vadop_sap = run("--broadphase vadop_sap " + shellQuote(scene));
    const ToolRun brute = run("--broadphase=brute " + shellQuote(scene));
    const ToolRun tuned = run(shellQuote(scene) + " --axes 64 --phi 0");
    for (const ToolRun* r : {&vadop, &sap, &brute, &tuned}) {
      ASSERT_EQ(r->status, 0) << r->err;
      EXPECT_EQ(r->err, "");
    }
    const size_t n = lines(vadop.out).size();
    EXPECT_GT(n, 200u) << "seed " << seed << ": too few contacts for a meaningful comparison";
    EXPECT_EQ(vadop.out, sap.out) << "seed " << seed;
    EXPECT_EQ(vadop.out, vadop_sap.out) << "seed " << seed;
    EXPECT_EQ(vadop.out, brute.out) << "seed " << seed;
    EXPECT_EQ(vadop.out, tuned.out) << "seed " << seed;
    // And the library, through the World API.
    const Scene s = parseScene(text);
    World w;
    addToWorld(s, w);
    EXPECT_EQ(impactsToJsonLines(w.predict(0.0, s.horizon)), vadop.out) << "seed " << seed;
    // Every line: a before b in input order, sorted by time, then input order.
    std::map<std::string, size_t> index;
    for (size_t i = 0; i < s.bodies.size(); ++i) index[s.bodies[i].id] = i;
    double last_t = -1;
    std::pair<size_t, size_t> last_pair{0, 0};
    for (const auto& l : lines(vadop.out)) {
      const auto j = nlohmann::json::parse(l);
      const size_t ia = index.at(j["a"].get<std::string>()), ib = index.at(j["b"].get<std::string>());
      EXPECT_LT(ia, ib) << l;
      const double t = j["time"].get<double>();
      ASSERT_GE(t, last_t) << l;
      if (t == last_t) EXPECT_LT(last_pair, std::make_pair(ia, ib)) << l;
      EXPECT_LE(t, s.horizon);
      last_t = t;
      last_pair = {ia, ib};
    }
    std::printf("seed %llu: 1000 bodies, %zu impact lines, identical for vadop, vadop_sap, sap, brute, vadop --axes 64 --phi 0\n",
                static_cast<unsigned long long>(100 + seed), n);
    total += n;
  }
  RecordProperty("impact_lines", static_cast<int>(total));
}

struct BadRun {
  const char* name;
  std::string args;       // shell words
  std::string stdin_text; // used when args reads stdin
  std::vector<std::string> needles;
};

TEST(VadopPredict, BadInputExitsWithStatus2AndPrintsNothing) {
  TempDir dir;
  const std::string ok_body = R"({"id": "a", "shape": {"type": "sphere", "radius": 1}, "position": [0, 0, 0]})";
  auto scene = [&](const std::string& second) { return R"({"horizon": 1, "bodies": [)" + ok_body + ", " + second + "]}"; };
  const std::vector<BadRun> cases = {
      {"negative radius", "-", scene(R"({"id": "b", "shape": {"type": "sphere", "radius": -1}, "position": [0, 0, 0]})"),
       {"body \"b\" (index 1)", "shape.radius", "got -1"}},
      {"overflow", "-", scene(R"({"id": "b", "shape": {"type": "sphere", "radius": 1}, "position": [0, 1e999, 0]})"),
       {"body \"b\" (index 1)", "position[1]", "1e999"}},
      {"typo", "-", scene(R"({"id": "b", "shape": {"type": "sphere", "radius": 1}, "position": [0, 0, 0], "linear_velocty": [1, 0, 0]})"),
       {"body \"b\" (index 1)", "linear_velocty"}},
      {"zero quaternion", "-", scene(R"({"id": "b", "shape": {"type": "sphere", "radius": 1}, "position": [0, 0, 0], "orientation": [0, 0, 0, 0]})"),
       {"body \"b\" (index 1)", "orientation"}},
      {"duplicate id", "-", scene(R"({"id": "a", "shape": {"type": "sphere", "radius": 1}, "position": [0, 0, 0]})"),
       {"body \"a\" (index 1)", "id"}},
      {"unknown shape", "-", scene(R"({"id": "b", "shape": {"type": "cone"}, "position": [0, 0, 0]})"),
       {"body \"b\" (index 1)", "shape.type"}},
      {"body not an object", "-", scene("[]"), {"body at index 1"}},
      {"negative horizon", "-", R"({"horizon": -2, "bodies": []})", {"horizon"}},
      {"malformed", "-", R"({"horizon": 1, "bodies": [)", {"malformed JSON"}},
      {"empty input", "", "", {"malformed JSON"}},
      {"missing file", shellQuote(dir.file("x") + ".does-not-exist"), "", {"does-not-exist"}},
      {"a directory", "/tmp", "", {"/tmp", "cannot read"}},
      {"unknown option", "--fast", "", {"--fast"}},
      {"axes 1", "--axes 1", "", {"--axes"}},
      {"axes not a number", "--axes many", "", {"--axes"}},
      {"phi 200", "--phi 200", "", {"--phi"}},
      {"phi below the covering radius", "--phi 5", "", {"phi", "covering radius"}},
      {"phi below the covering radius, sap", "--broadphase sap --phi 5", "", {"phi", "covering radius"}},
      {"axes 1, brute", "--axes 1 --broadphase brute", "", {"--axes"}},
      {"unknown broad phase", "--broadphase kdop", "", {"kdop"}},
      {"missing value", "--broadphase", "", {"--broadphase"}},
      {"two files", "a.json b.json", "", {"more than one"}},
  };
  for (const BadRun& c : cases) {
    const std::string in = dir.file(std::string("in_") + std::to_string(&c - cases.data()), c.stdin_text);
    const ToolRun r = run(c.args, in);
    EXPECT_EQ(r.status, 2) << c.name << ": " << r.err;
    EXPECT_EQ(r.out, "") << c.name;
    ASSERT_FALSE(r.err.empty()) << c.name;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << c.name << ": not one line: " << r.err;
    for (const auto& needle : c.needles) {
      EXPECT_NE(r.err.find(needle), std::string::npos) << c.name << ": \"" << needle << "\" not in: " << r.err;
    }
  }
}

TEST(VadopPredict, BadBodyAfterManyContactsPrintsNothing) {
  // 1,000 valid, colliding bodies, then a bad one: nothing may be printed.
  std::string text = testing_scene::randomSceneJson(7);
  const size_t end = text.rfind(']');
  text.insert(end, R"(,{"id": "last", "shape": {"type": "box", "size": [1, 0, 1]}, "position": [0, 0, 0]})");
  TempDir dir;
  const ToolRun r = run("-", dir.file("scene.json", text));
  EXPECT_EQ(r.status, 2);
  EXPECT_EQ(r.out, "");
  EXPECT_NE(r.err.find("body \"last\" (index 1000): shape.size[1]"), std::string::npos) << r.err;
}

TEST(VadopPredict, HelpPrintsUsage) {
  const ToolRun r = run("--help");
  EXPECT_EQ(r.status, 0);
  EXPECT_EQ(r.out.rfind("usage: vadop_predict", 0), 0u) << r.out;
  EXPECT_NE(r.out.find("--broadphase"), std::string::npos);
  EXPECT_EQ(r.err, "");
}

}  // namespace
}  // namespace vadop
