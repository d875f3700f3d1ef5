// vadop_predict, the command-line tool, run as a process (VADOP_PREDICT_BIN):
//  - a small analytic scene whose output lines are computed by hand;
//  - --broadphase vadop|vadop_sap|sap|grid|brute print byte-identical output on random 1,000-body scenes
//    (and the same as the World API);
//  - bad input or options: exit status 2, a one-line message naming body and field on stderr,
//    nothing on stdout; --help: usage, exit 0;
//  - hostile input (issue 13): 80,000 levels of nesting, /dev/zero, a NUL byte, megabyte ids and
//    keys, values beyond the range of error.h: exit status 2 with one bounded line, quickly;
//    quaternions whose norm overflows or underflows are rotations; values at the range's edge work.
// The tool under test is the one built with these tests (VADOP_PREDICT_BIN), or the one named by
// the environment variable VADOP_PREDICT_BIN (to show a test failing on another build).
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
#include <set>
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

std::string toolPath() {
  const char* env = std::getenv("VADOP_PREDICT_BIN");
  return env && *env ? env : VADOP_PREDICT_BIN;
}

// Runs vadop_predict with `args` (already shell-quoted where needed), stdin from `input_file`
// (through a pipe when `pipe`); `wrapper` (such as "timeout 20") goes before the tool.
ToolRun run(const std::string& args, const std::string& input_file = "/dev/null", const std::string& wrapper = "",
            bool pipe = false) {
  TempDir dir;
  const std::string out = dir.file("stdout"), err = dir.file("stderr");
  const std::string tool = wrapper + " " + shellQuote(toolPath()) + " " + args;
  const std::string cmd = (pipe ? "cat " + shellQuote(input_file) + " | " + tool : tool + " < " + shellQuote(input_file)) +
                          " > " + shellQuote(out) + " 2> " + shellQuote(err);
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
    const ToolRun grid = run("--broadphase grid " + shellQuote(scene));
    const ToolRun tuned = run(shellQuote(scene) + " --axes 64 --phi 0");
    for (const ToolRun* r : {&vadop, &sap, &vadop_sap, &brute, &grid, &tuned}) {
      ASSERT_EQ(r->status, 0) << r->err;
      EXPECT_EQ(r->err, "");
    }
    const size_t n = lines(vadop.out).size();
    EXPECT_GT(n, 200u) << "seed " << seed << ": too few contacts for a meaningful comparison";
    EXPECT_EQ(vadop.out, sap.out) << "seed " << seed;
    EXPECT_EQ(vadop.out, vadop_sap.out) << "seed " << seed;
    EXPECT_EQ(vadop.out, brute.out) << "seed " << seed;
    EXPECT_EQ(vadop.out, grid.out) << "seed " << seed;
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

TEST(VadopPredict, ScenesWithPathsPrintByteIdenticalOutput) {
  TempDir dir;
  testing_scene::GenParams gp;
  gp.n = 600;
  gp.path_fraction = 0.05;
  const std::string text = testing_scene::randomSceneJson(42, gp);
  const std::string scene = dir.file("paths.json", text);
  const Scene parsed = parseScene(text);
  std::set<std::string> on_path;
  for (const SceneBody& b : parsed.bodies) {
    if (b.path) on_path.insert(b.id);
  }
  EXPECT_GT(on_path.size(), 15u);
  const ToolRun vadop = run(shellQuote(scene));
  ASSERT_EQ(vadop.status, 0) << vadop.err;
  for (const char* kind : {"vadop_sap", "sap", "grid", "brute"}) {
    const ToolRun r = run("--broadphase " + std::string(kind) + " " + shellQuote(scene));
    ASSERT_EQ(r.status, 0) << kind << ": " << r.err;
    EXPECT_EQ(r.out, vadop.out) << kind;
  }
  size_t path_lines = 0;
  for (const auto& l : lines(vadop.out)) {
    const auto j = nlohmann::json::parse(l);
    path_lines += on_path.count(j["a"].get<std::string>()) || on_path.count(j["b"].get<std::string>());
  }
  EXPECT_GT(path_lines, 20u);  // not vacuous: the paths meet the others
  std::printf("%zu bodies on paths, %zu impact lines, %zu of them with a path body\n", on_path.size(),
              lines(vadop.out).size(), path_lines);
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
      {"path times not increasing", "-",
       scene(R"({"id": "b", "shape": {"type": "sphere", "radius": 1}, "path": [{"t": 1, "position": [0, 0, 0]}, {"t": 1, "position": [1, 0, 0]}]})"),
       {"body \"b\" (index 1)", "keyframe 1", "does not increase"}},
      {"path and velocity", "-",
       scene(R"({"id": "b", "shape": {"type": "sphere", "radius": 1}, "linear_velocity": [1, 0, 0], "path": [{"t": 0, "position": [0, 0, 0]}]})"),
       {"body \"b\" (index 1)", "linear_velocity", "path"}},
      {"path keyframe without position", "-",
       scene(R"({"id": "b", "shape": {"type": "sphere", "radius": 1}, "path": [{"t": 0}]})"),
       {"body \"b\" (index 1)", "path[0].position", "missing"}},
      {"after_path unknown", "-",
       scene(R"({"id": "b", "shape": {"type": "sphere", "radius": 1}, "path": [{"t": 0, "position": [0, 0, 0]}], "after_path": "stop"})"),
       {"body \"b\" (index 1)", "after_path", "stop"}},
      {"after_path without a path", "-",
       scene(R"({"id": "b", "shape": {"type": "sphere", "radius": 1}, "position": [0, 0, 0], "after_path": "hold"})"),
       {"body \"b\" (index 1)", "after_path", "needs a path"}},
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

// The longest line vadop_predict may print on stderr, newline included (vadop_predict.cpp).
constexpr size_t kMaxLineBytes = kMaxMessageBytes + 100;

// Exit status 2, nothing on stdout, one line of at most kMaxLineBytes on stderr holding every needle.
void expectRejected(const ToolRun& r, const std::string& name, const std::vector<std::string>& needles) {
  EXPECT_EQ(r.status, 2) << name << ": " << r.err.substr(0, 1000);
  EXPECT_EQ(r.out.size(), 0u) << name;
  EXPECT_FALSE(r.err.empty()) << name;
  EXPECT_LE(r.err.size(), kMaxLineBytes) << name << ": " << r.err.size() << " bytes: " << r.err.substr(0, 1000);
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << name << ": not one line: " << r.err.substr(0, 1000);
  if (!r.err.empty()) EXPECT_EQ(r.err.back(), '\n') << name;
  for (const auto& needle : needles) {
    EXPECT_NE(r.err.find(needle), std::string::npos) << name << ": \"" << needle << "\" not in: " << r.err.substr(0, 1000);
  }
}

TEST(VadopPredict, NestingOf80000LevelsIsRejectedWithoutRecursing) {
  // Issue 13, 3: {"horizon": [[[...]]], "bodies": []}, 160 KB. It overflowed the stack
  // (segfault) serializing the value into the message.
  TempDir dir;
  const size_t n = 80000;
  const std::string text = R"({"horizon": )" + std::string(n, '[') + std::string(n, ']') + R"(, "bodies": []})";
  const std::string file = dir.file("deep.json", text);
  const std::vector<std::string> needles = {"horizon[0][0]", "nested deeper than 64 levels"};
  expectRejected(run(shellQuote(file), "/dev/null", "timeout 60"), "file", needles);
  expectRejected(run("-", file, "timeout 60"), "stdin", needles);
  // The same with objects, inside a body: the path names the body.
  std::string objects = R"({"horizon": 1, "bodies": [{"id": "a", "shape": )";
  for (size_t i = 0; i < n; ++i) objects += R"({"k": )";
  objects += "1" + std::string(n, '}') + "}]}";
  expectRejected(run(shellQuote(dir.file("deep_objects.json", objects)), "/dev/null", "timeout 60"), "objects",
                 {"body \"a\" (index 0): shape.k.k.k", "nested deeper than 64 levels"});
}

TEST(VadopPredict, InputIsReadUpToTheSizeLimitOnly) {
  // Issue 13, 9: /dev/zero was read until allocation failed (~1 GB, 10 s and more).
  // No wall-clock assertion (the machine may be loaded): the old tool never got to a message
  // naming the limit (killed by the timeout, or out of memory), which expectRejected requires.
  expectRejected(run("/dev/zero", "/dev/null", "timeout 20"), "/dev/zero", {"/dev/zero", "larger than 64 MiB"});
  expectRejected(run("-", "/dev/zero", "timeout 20"), "stdin from /dev/zero", {"standard input", "larger than 64 MiB"});
  // A pipe, and a regular file, one byte over the limit.
  TempDir dir;
  const std::string pad = dir.file("pad");
  ASSERT_EQ(truncate(pad.c_str(), static_cast<off_t>(kMaxSceneBytes + 1)), 0);
  expectRejected(run(shellQuote(pad), "/dev/null", "timeout 20"), "limit + 1, file", {"larger than 64 MiB"});
  expectRejected(run("", pad, "timeout 20", true), "limit + 1, pipe", {"standard input", "larger than 64 MiB"});
  // A scene of exactly kMaxSceneBytes (padded with spaces) is read, from a file and a pipe.
  std::string text = R"({"horizon": 1, "bodies": [{"id": "a", "shape": {"type": "sphere", "radius": 1}, "position": [0, 0, 0]},
                                                   {"id": "b", "shape": {"type": "sphere", "radius": 1}, "position": [1, 0, 0]}]})";
  text.resize(kMaxSceneBytes, ' ');
  const std::string full = dir.file("full.json", text);
  text.clear();
  text.shrink_to_fit();
  for (const ToolRun& r : {run(shellQuote(full), "/dev/null", "timeout 20"), run("-", full, "timeout 20", true)}) {
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(r.err, "");
    EXPECT_EQ(r.out.rfind(R"({"a":"a","b":"b","time":0.0,)", 0), 0u) << r.out;
  }
}

TEST(VadopPredict, ANulByteDoesNotEndTheInput) {
  // Issue 13, 11: {"horizon":2,"bodies":[]}\0garbage was accepted (the parser stopped at the NUL).
  TempDir dir;
  const std::string scene = R"({"horizon":2,"bodies":[]})";
  const std::string garbage = dir.file("garbage.json", scene + std::string(1, '\0') + "garbage");
  expectRejected(run(shellQuote(garbage)), "file", {"NUL byte", "byte 26"});
  expectRejected(run("-", garbage), "stdin", {"NUL byte", "byte 26"});
  expectRejected(run("-", dir.file("nul_end.json", scene + std::string(1, '\0'))), "a trailing NUL", {"NUL byte"});
  expectRejected(run("-", dir.file("nul_inside.json", R"({"horizon":)" + std::string(1, '\0') + "2}")), "a NUL inside",
                 {"NUL byte", "byte 12"});
  // Without the NUL the scene is fine.
  const ToolRun ok = run("-", dir.file("ok.json", scene + "  \n"));
  EXPECT_EQ(ok.status, 0) << ok.err;
  EXPECT_EQ(ok.out, "");
}

std::string repeat(const std::string& s, size_t n) {
  std::string out;
  out.reserve(s.size() * n);
  for (size_t i = 0; i < n; ++i) out += s;
  return out;
}

TEST(VadopPredict, EveryMessageIsOneLineOfBoundedLength) {
  // Issue 13, 11: 3 MB of unterminated nesting gave a 9 MB message, a 1 MB id a 1 MB one.
  TempDir dir;
  const std::string mb(1 << 20, 'x');
  const std::string sphere = R"("shape": {"type": "sphere", "radius": 1})";
  std::string long_keys = R"({"horizon": )";
  for (int i = 0; i < 60; ++i) long_keys += "{\"" + std::string(100000, static_cast<char>('a' + i % 26)) + "\": ";
  const std::vector<BadRun> cases = {
      {"3 MB unterminated nesting", "-", R"({"horizon": 1, "bodies": [)" + std::string(3000000, '['),
       {"bodies[0][0]", "nested deeper than 64 levels"}},
      {"1 MB id", "-", R"({"horizon": 1, "bodies": [{"id": ")" + mb + R"(", "shape": {"type": "sphere", "radius": -1}, "position": [0, 0, 0]}]})",
       {"body \"xxxxxxxx", "...\" (index 0): shape.radius", "got -1"}},
      {"1 MB unknown key", "-", R"({"horizon": 1, "bodies": [{"id": "a", )" + sphere + R"(, "position": [0, 0, 0], ")" + mb + R"(": 1}]})",
       {"body \"a\" (index 0)", "unknown key \"xxxx"}},
      {"1 MB duplicate key", "-", R"({"horizon": 1, ")" + mb + R"(": 1, ")" + mb + R"(": 2, "bodies": []})",
       {"\"xxxx", "given twice"}},
      {"1 MB string as a number", "-", R"({"horizon": ")" + mb + R"(", "bodies": []})", {"horizon", "must be a number"}},
      {"1 MB array as a number", "-", R"({"horizon": [1)" + repeat(",1", 1 << 19) + R"(], "bodies": []})",
       {"horizon", "must be a number", "got array [1,1,1,"}},
      {"1 MB number that overflows", "-", R"({"horizon": 1)" + std::string(1 << 20, '0') + R"(, "bodies": []})",
       {"horizon", "finite"}},
      {"1 MB unterminated string", "-", R"({"horizon": 1, "bodies": [{"id": ")" + mb, {"body at index 0: id", "malformed JSON"}},
      {"60 levels of 100 KB keys, unterminated", "-", long_keys, {"horizon", "malformed JSON"}},
      {"a 3,000-byte file name", shellQuote(dir.file("x") + std::string(3000, 'y')), "", {"cannot", "yyyy..."}},
      {"a 100 KB option value", "--axes " + std::string(100000, '7'), "", {"--axes", "777..."}},
      {"a 100 KB unknown option", "--" + std::string(100000, 'o'), "", {"unknown option", "ooo..."}},
  };
  for (const BadRun& c : cases) {
    const std::string in = dir.file(std::string("in_") + std::to_string(&c - cases.data()), c.stdin_text);
    expectRejected(run(c.args, in, "timeout 60"), c.name, c.needles);
  }
}

TEST(VadopPredict, QuaternionsAreNormalisedScaleSafely) {
  // Issue 13, 11: [0, 0, 1e200, 1e200] (its norm overflows) and [0, 0, 1e-200, 1e-200] (its squares
  // underflow) are the quarter turn about z that [0, 0, 1, 1] is; only a real zero is rejected.
  TempDir dir;
  // A 4 m bar along x turned to lie along y touches the ball at y = 1.9 at t = 0.
  auto scene = [](const std::string& q) {
    return R"({"horizon": 1, "bodies": [{"id": "bar", "shape": {"type": "box", "size": [4, 0.2, 0.2]}, "position": [0, 0, 0],
               "orientation": )" + q + R"(}, {"id": "ball", "shape": {"type": "sphere", "radius": 0.1}, "position": [0, 2.05, 0]}]})";
  };
  const ToolRun unit = run("-", dir.file("unit.json", scene("[0, 0, 1, 1]")));
  ASSERT_EQ(unit.status, 0) << unit.err;
  ASSERT_EQ(lines(unit.out).size(), 1u) << unit.out;
  EXPECT_EQ(unit.out.rfind(R"({"a":"bar","b":"ball","time":0.0,)", 0), 0u) << unit.out;
  for (const char* q : {"[0, 0, 1e200, 1e200]", "[0, 0, 1e-200, 1e-200]", "[0, 0, 5e-324, 5e-324]", "[0, 0, 1.7e308, 1.7e308]"}) {
    const ToolRun r = run("-", dir.file("q.json", scene(q)));
    EXPECT_EQ(r.status, 0) << q << ": " << r.err;
    EXPECT_EQ(r.out, unit.out) << q;
  }
  expectRejected(run("-", dir.file("zero.json", scene("[0, -0.0, 0, 0]"))), "zero", {"body \"bar\" (index 0)", "orientation", "non-zero"});
}

TEST(VadopPredict, ValuesBeyondTheRangeAreRejectedNamingTheField) {
  // Issue 13, 10: two 0.5 m boxes 1 cm apart at x = 1e12 were reported touching (a double there
  // is exact to 1.2e-4 m only); spheres of radius 1e149 at +-1e150 closing at 1e150 m/s exited 0
  // with no contact.
  TempDir dir;
  auto body = [](const std::string& id, const std::string& shape, const std::string& rest) {
    return R"({"id": ")" + id + R"(", "shape": )" + shape + ", " + rest + "}";
  };
  auto scene = [](const std::string& bodies, const std::string& horizon = "1") {
    return R"({"horizon": )" + horizon + R"(, "bodies": [)" + bodies + "]}";
  };
  const std::string box = R"({"type": "box", "size": [0.5, 0.5, 0.5]})";
  const std::string ball = R"({"type": "sphere", "radius": 1})";
  const std::vector<BadRun> cases = {
      {"boxes at x = 1e12", "-",
       scene(body("a", box, R"("position": [1e12, 0, 0])") + ", " + body("b", box, R"("position": [1000000000000.51, 0, 0])")),
       {"body \"a\" (index 0): position[0]", "beyond"}},
      {"spheres of radius 1e149", "-",
       scene(body("a", R"({"type": "sphere", "radius": 1e149})", R"("position": [-1e150, 0, 0], "linear_velocity": [1e150, 0, 0])") +
             ", " + body("b", R"({"type": "sphere", "radius": 1e149})", R"("position": [1e150, 0, 0], "linear_velocity": [-1e150, 0, 0])")),
       {"body \"a\" (index 0): shape.radius", "beyond"}},
      {"closing at 1e150 m/s", "-", scene(body("a", ball, R"("position": [0, 0, 0], "linear_velocity": [1e150, 0, 0])")),
       {"body \"a\" (index 0): linear_velocity[0]", "beyond"}},
      {"speed by its norm", "-", scene(body("a", ball, R"("position": [0, 0, 0], "linear_velocity": [8000, 8000, 0])")),
       {"body \"a\" (index 0): |linear_velocity|", "beyond"}},
      {"spinning at 1e5 rad/s", "-", scene(body("a", ball, R"("position": [0, 0, 0], "angular_velocity": [0, 0, -1e5])")),
       {"body \"a\" (index 0): angular_velocity[2]", "beyond"}},
      {"position at -2e7", "-", scene(body("a", ball, R"("position": [0, -2e7, 0])")), {"position[1]", "beyond"}},
      {"box edge 1e6", "-", scene(body("a", R"({"type": "box", "size": [1, 1e6, 1]})", R"("position": [0, 0, 0])")),
       {"shape.size[1]", "beyond"}},
      {"capsule length 2e5", "-", scene(body("a", R"({"type": "capsule", "radius": 1, "length": 2e5})", R"("position": [0, 0, 0])")),
       {"shape.length", "beyond"}},
      {"convex point at 1e6", "-",
       scene(body("a", R"({"type": "convex", "points": [[0, 0, 0], [1, 0, 0], [0, 0, 1e6]]})", R"("position": [0, 0, 0])")),
       {"shape.points[2][2]", "beyond"}},
      {"mesh vertex by its norm", "-",
       scene(body("a", R"({"type": "mesh", "vertices": [[0, 0, 0], [9e4, 9e4, 0], [0, 1, 0]], "triangles": [[0, 1, 2]]})",
                  R"("position": [0, 0, 0])")),
       {"|shape.vertices[1]|", "beyond"}},
      {"horizon 1e8 s", "-", scene("", "1e8"), {"horizon", "beyond"}},
  };
  for (const BadRun& c : cases) {
    expectRejected(run(c.args, dir.file("in_" + std::to_string(&c - cases.data()), c.stdin_text)), c.name, c.needles);
  }
}

TEST(VadopPredict, ValuesAtTheEdgeOfTheRangeWork) {
  TempDir dir;
  // 0.5 m boxes 1 cm apart at x = 1e7 - 1 (kMaxCoordinate - 1), closing at 0.02 m/s: contact when the gap is
  // 5e-7 m, at t = (0.01 - 5e-7) / 0.02.
  const ToolRun boxes = run("-", dir.file("boxes.json", R"({"horizon": 1, "bodies": [
      {"id": "a", "shape": {"type": "box", "size": [0.5, 0.5, 0.5]}, "position": [9999999, 0, 0], "linear_velocity": [0.01, 0, 0]},
      {"id": "b", "shape": {"type": "box", "size": [0.5, 0.5, 0.5]}, "position": [9999999.51, 0, 0], "linear_velocity": [-0.01, 0, 0]}]})"));
  ASSERT_EQ(boxes.status, 0) << boxes.err;
  ASSERT_EQ(lines(boxes.out).size(), 1u) << boxes.out;
  const auto j = nlohmann::json::parse(boxes.out);
  EXPECT_NEAR(j["time"].get<double>(), (0.01 - 5e-7) / 0.02, 1e-6) << boxes.out;
  EXPECT_NEAR(j["point"][0].get<double>(), 9999999.255, 1e-6) << boxes.out;
  // Spheres of radius kMaxSize 1.8e6 m apart (surfaces), closing at 2 kMaxLinearSpeed: t = 90 s.
  const ToolRun spheres = run("-", dir.file("spheres.json", R"({"horizon": 100, "bodies": [
      {"id": "a", "shape": {"type": "sphere", "radius": 1e5}, "position": [-1e6, 0, 0], "linear_velocity": [1e4, 0, 0]},
      {"id": "b", "shape": {"type": "sphere", "radius": 1e5}, "position": [1e6, 0, 0], "linear_velocity": [-1e4, 0, 0],
       "angular_velocity": [0, 0, 1e4]}]})"));
  ASSERT_EQ(spheres.status, 0) << spheres.err;
  ASSERT_EQ(lines(spheres.out).size(), 1u) << spheres.out;
  EXPECT_NEAR(nlohmann::json::parse(spheres.out)["time"].get<double>(), 90.0, 1e-6) << spheres.out;
  // A horizon of kMaxTime, with bodies at the coordinate limit that never meet.
  const ToolRun longest = run("-", dir.file("long.json", R"({"horizon": 1e7, "bodies": [
      {"id": "a", "shape": {"type": "sphere", "radius": 1}, "position": [1e7, -1e7, 1e7]},
      {"id": "b", "shape": {"type": "sphere", "radius": 1}, "position": [-1e7, 1e7, -1e7]}]})"));
  EXPECT_EQ(longest.status, 0) << longest.err;
  EXPECT_EQ(longest.out, "");
}

TEST(VadopPredict, UndecidedPairsPrintAsSuchNeverAsContacts) {
  // With a budget of one distance evaluation the spinning arm and the wall are undecided (the arm's
  // corner passes 2.4e-6 m from the wall at t = 0.0997); the spheres (closed form) still touch
  // at t = 0.25 - 2.5e-7. Undecided lines are never contacts, the same for every broad phase.
  TempDir dir;
  const std::string scene = dir.file("scene.json", R"({"horizon": 1, "bodies": [
      {"id": "arm", "shape": {"type": "box", "size": [2, 0.2, 0.2]}, "position": [0, 0, 0], "angular_velocity": [0, 0, -1]},
      {"id": "wall", "shape": {"type": "box", "size": [1, 1, 1]}, "position": [1.50499, 0, 0]},
      {"id": "l", "shape": {"type": "sphere", "radius": 0.5}, "position": [10, 0, 0], "linear_velocity": [1, 0, 0]},
      {"id": "r", "shape": {"type": "sphere", "radius": 0.5}, "position": [11.5, 0, 0], "linear_velocity": [-1, 0, 0]}]})");
  const ToolRun full = run(shellQuote(scene));
  ASSERT_EQ(full.status, 0) << full.err;
  EXPECT_EQ(full.out.find("undecided"), std::string::npos) << full.out;
  std::map<std::string, std::string> by_kind;
  for (const char* broad : {"vadop", "vadop_sap", "sap", "brute"}) {
    const ToolRun r = run(shellQuote(scene) + " --max-iterations 1 --broadphase " + broad);
    ASSERT_EQ(r.status, 0) << broad << ": " << r.err;
    EXPECT_EQ(r.err, "");
    const auto out = lines(r.out);
    ASSERT_EQ(out.size(), 2u) << broad << ": " << r.out;
    // Sorted together by time: the undecided line's undecided_after against the contact's time.
    const size_t u = out[0].find("undecided_after") != std::string::npos ? 0 : 1;
    const auto open = nlohmann::json::parse(out[u]);
    const auto contact = nlohmann::json::parse(out[1 - u]);
    EXPECT_EQ(out[u].rfind(R"({"a":"arm","b":"wall","undecided_after":)", 0), 0u) << out[u];
    EXPECT_EQ(open.size(), 3u) << out[u];
    const double after = open["undecided_after"].get<double>();
    EXPECT_GE(after, 0.0);
    EXPECT_LT(after, 1.0);
    EXPECT_EQ(out[1 - u].rfind(R"({"a":"l","b":"r","time":0.2499997)", 0), 0u) << out[1 - u];
    EXPECT_EQ(u == 0, after <= contact["time"].get<double>()) << r.out;
    by_kind[broad] = r.out;
  }
  EXPECT_EQ(by_kind["vadop"], by_kind["sap"]);
  EXPECT_EQ(by_kind["vadop"], by_kind["brute"]);
  EXPECT_EQ(by_kind["vadop"], by_kind["vadop_sap"]);
  expectRejected(run("--max-iterations 0"), "budget 0", {"--max-iterations"});
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
