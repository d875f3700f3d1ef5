// Scene reading (JSON -> shapes and motions) and impact formatting (JSON lines):
//  - every shape type is read with URDF conventions; defaults for orientation and velocities;
//  - every kind of bad input throws vadop::InvalidArgument with a one-line message that names
//    the body (id and index, or index) and the field;
//  - impact lines have a fixed key order and numbers that read back to the same doubles;
//  - the fuzz seed corpus consists of valid scenes.
#include "vadop/error.h"
#include "vadop/scene_io.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <dirent.h>
#include <unistd.h>
#include <fstream>
#include <random>
#include <string>
#include <vector>

namespace vadop {
namespace {

std::string oneBody(const std::string& body_fields, double horizon = 1.0) {
  return "{\"horizon\": " + std::to_string(horizon) + ", \"bodies\": [" + body_fields + "]}";
}

std::string withShape(const std::string& shape, const std::string& id = "s") {
  return oneBody("{\"id\": \"" + id + "\", \"shape\": " + shape + ", \"position\": [1, 2, 3]}");
}

TEST(SceneIo, ReadsEveryShapeType) {
  {
    const Scene s = parseScene(withShape(R"({"type": "sphere", "radius": 0.5})"));
    ASSERT_EQ(s.bodies.size(), 1u);
    EXPECT_EQ(s.bodies[0].id, "s");
    EXPECT_EQ(s.bodies[0].shape.type, ShapeType::kSphere);
    EXPECT_EQ(s.bodies[0].shape.radius, 0.5);
  }
  {
    const Shape b = parseScene(withShape(R"({"type": "box", "size": [1, 2, 4]})")).bodies[0].shape;
    EXPECT_EQ(b.type, ShapeType::kBox);
    EXPECT_EQ(b.half_extents, Eigen::Vector3d(0.5, 1, 2));  // size = full edge lengths
  }
  {
    const Shape c = parseScene(withShape(R"({"type": "cylinder", "radius": 0.25, "length": 3})")).bodies[0].shape;
    EXPECT_EQ(c.type, ShapeType::kCylinder);
    EXPECT_EQ(c.radius, 0.25);
    EXPECT_EQ(c.half_length, 1.5);  // full height 3, along z
    EXPECT_EQ(support(c, Eigen::Vector3d::UnitZ()), 1.5);
  }
  {
    const Shape c = parseScene(withShape(R"({"type": "capsule", "radius": 0.25, "length": 3})")).bodies[0].shape;
    EXPECT_EQ(c.type, ShapeType::kCapsule);
    EXPECT_EQ(c.radius, 0.25);
    EXPECT_EQ(c.half_length, 1.5);  // segment length 3: caps beyond
    EXPECT_EQ(support(c, Eigen::Vector3d::UnitZ()), 1.75);
    const Shape ball = parseScene(withShape(R"({"type": "capsule", "radius": 0.25, "length": 0})")).bodies[0].shape;
    EXPECT_EQ(ball.half_length, 0.0);
  }
  {
    const Shape c = parseScene(withShape(R"({"type": "convex", "points": [[1, 0, 0], [0, 2, 0], [0, 0, -3]]})"))
                        .bodies[0]
                        .shape;
    EXPECT_EQ(c.type, ShapeType::kConvex);
    ASSERT_EQ(c.points.size(), 3u);
    EXPECT_EQ(c.points[1], Eigen::Vector3d(0, 2, 0));
    EXPECT_EQ(c.points[2], Eigen::Vector3d(0, 0, -3));
  }
  {
    const Shape m = parseScene(withShape(R"({"type": "mesh", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]],
                                              "triangles": [[0, 1, 2], [0, 3, 1]]})"))
                        .bodies[0]
                        .shape;
    EXPECT_EQ(m.type, ShapeType::kMesh);
    ASSERT_EQ(m.points.size(), 4u);
    EXPECT_EQ(m.points[3], Eigen::Vector3d(0, 0, 1));
    ASSERT_EQ(m.triangles.size(), 2u);
    EXPECT_EQ(m.triangles[1], (std::array<int, 3>{0, 3, 1}));
  }
}

TEST(SceneIo, ReadsMotionsWithDefaults) {
  const Scene s = parseScene(R"({"horizon": 2.5, "bodies": [
      {"id": "plain", "shape": {"type": "sphere", "radius": 1}, "position": [1, -2, 3.5]},
      {"id": "full", "shape": {"type": "sphere", "radius": 1}, "position": [0, 0, 0],
       "orientation": [0, 0, 0.7071067811865476, 0.7071067811865476],
       "linear_velocity": [1, 2, 3], "angular_velocity": [0, 0, -0.5]},
      {"id": "scaled", "shape": {"type": "sphere", "radius": 1}, "position": [0, 0, 0],
       "orientation": [0, 0, 2, 0]},
      {"id": "huge", "shape": {"type": "sphere", "radius": 1}, "position": [0, 0, 0],
       "orientation": [1e300, 0, 0, 1e300]}]})");
  EXPECT_EQ(s.horizon, 2.5);
  ASSERT_EQ(s.bodies.size(), 4u);
  const Motion& plain = s.bodies[0].motion;
  EXPECT_EQ(plain.position, Eigen::Vector3d(1, -2, 3.5));
  EXPECT_EQ(plain.orientation.coeffs(), Eigen::Quaterniond::Identity().coeffs());
  EXPECT_EQ(plain.linear_velocity, Eigen::Vector3d::Zero());
  EXPECT_EQ(plain.angular_velocity, Eigen::Vector3d::Zero());
  EXPECT_EQ(plain.t_ref, 0.0);
  const Motion& full = s.bodies[1].motion;
  // [x, y, z, w]: a quarter turn about z takes x to y.
  EXPECT_NEAR((full.orientation * Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitY()).norm(), 0.0, 1e-12);
  EXPECT_EQ(full.linear_velocity, Eigen::Vector3d(1, 2, 3));
  EXPECT_EQ(full.angular_velocity, Eigen::Vector3d(0, 0, -0.5));
  // Normalised on reading: [0, 0, 2, 0] is a half turn about z.
  EXPECT_NEAR(s.bodies[2].motion.orientation.norm(), 1.0, 1e-15);
  EXPECT_NEAR((s.bodies[2].motion.orientation * Eigen::Vector3d::UnitX() + Eigen::Vector3d::UnitX()).norm(), 0.0, 1e-12);
  // Components near the top of the double range normalise without overflow: a quarter turn about x.
  EXPECT_NEAR((s.bodies[3].motion.orientation * Eigen::Vector3d::UnitY() - Eigen::Vector3d::UnitZ()).norm(), 0.0, 1e-12);
  // Bodies keep the input order.
  EXPECT_EQ(s.bodies[0].id, "plain");
  EXPECT_EQ(s.bodies[3].id, "huge");
  // An empty scene is valid.
  EXPECT_TRUE(parseScene(R"({"horizon": 0, "bodies": []})").bodies.empty());
}

struct BadCase {
  const char* name;
  std::string text;
  std::vector<std::string> needles;  // every one must appear in the message
};

std::string body(const std::string& fields) { return oneBody(fields); }
const char* kShape = R"("shape": {"type": "sphere", "radius": 1})";

std::vector<BadCase> badCases() {
  const std::string b0 = std::string(R"({"id": "a", )") + kShape + R"(, "position": [0, 0, 0]})";
  auto second = [&](const std::string& fields) { return oneBody(b0 + ", " + fields); };
  auto b = [&](const std::string& rest) {  // body "b" at index 1
    return second(R"({"id": "b", )" + rest + "}");
  };
  auto shaped = [&](const std::string& shape) { return b(R"("shape": )" + shape + R"(, "position": [0, 0, 0])"); };
  const std::string B = "body \"b\" (index 1)";
  return {
      // Malformed JSON and the top level.
      {"empty input", "", {"malformed JSON", "line 1"}},
      {"syntax error", R"({"horizon": 1, "bodies": [}])", {"malformed JSON"}},
      {"syntax error in a body", b(std::string(kShape) + R"(, "position": [0, 0 0])"), {B, "position", "malformed JSON"}},
      {"trailing text", R"({"horizon": 1, "bodies": []} x)", {"malformed JSON"}},
      {"not an object", "[1, 2]", {"scene", "must be a JSON object"}},
      {"missing horizon", R"({"bodies": []})", {"horizon", "missing"}},
      {"negative horizon", R"({"horizon": -1, "bodies": []})", {"horizon", ">= 0", "-1"}},
      {"horizon overflows", R"({"horizon": 1e999, "bodies": []})", {"horizon", "finite", "1e999"}},
      {"horizon as a string", R"({"horizon": "2", "bodies": []})", {"horizon", "must be a number", "\"2\""}},
      {"missing bodies", R"({"horizon": 1})", {"bodies", "missing"}},
      {"bodies not an array", R"({"horizon": 1, "bodies": {}})", {"bodies", "must be an array"}},
      {"unknown top-level key", R"({"horizon": 1, "bodies": [], "bodys": []})", {"unknown key \"bodys\""}},
      {"duplicate top-level key", R"({"horizon": 1, "horizon": 2, "bodies": []})", {"horizon", "duplicate"}},
      // Bodies and ids.
      {"body not an object", second("42"), {"body at index 1", "must be a JSON object"}},
      {"missing id", second(std::string("{") + kShape + R"(, "position": [0, 0, 0]})"), {"body at index 1", "id", "missing"}},
      {"id not a string", second(std::string(R"({"id": 7, )") + kShape + R"(, "position": [0, 0, 0]})"),
       {"body at index 1", "id", "non-empty string"}},
      {"empty id", second(std::string(R"({"id": "", )") + kShape + R"(, "position": [0, 0, 0]})"),
       {"body at index 1", "id", "non-empty string"}},
      {"duplicate id", second(std::string(R"({"id": "a", )") + kShape + R"(, "position": [0, 0, 0]})"),
       {"body \"a\" (index 1)", "id", "already used", "index 0"}},
      {"unknown body key (typo)", b(std::string(kShape) + R"(, "position": [0, 0, 0], "linear_velocty": [1, 0, 0])"),
       {B, "unknown key \"linear_velocty\""}},
      {"duplicate key with a newline", R"({"horizon": 1, "bodies": [{"a\nb": 1, "a\nb": 2}]})",
       {"body at index 0", "\"a\\nb\"", "given twice"}},
      {"duplicate body key", b(std::string(kShape) + R"(, "position": [0, 0, 0], "position": [1, 0, 0])"),
       {"index 1", "position", "duplicate"}},
      // Shapes.
      {"missing shape", b(R"("position": [0, 0, 0])"), {B, "shape", "missing"}},
      {"shape not an object", shaped("\"sphere\""), {B, "shape", "must be an object"}},
      {"missing type", shaped(R"({"radius": 1})"), {B, "shape.type", "missing"}},
      {"unknown type", shaped(R"({"type": "cone", "radius": 1})"), {B, "shape.type", "\"cone\""}},
      {"negative radius", shaped(R"({"type": "sphere", "radius": -1})"), {B, "shape.radius must be finite and > 0, got -1"}},
      {"zero radius", shaped(R"({"type": "sphere", "radius": 0})"), {B, "shape.radius", "> 0", "got 0"}},
      {"radius overflows", shaped(R"({"type": "sphere", "radius": 1e999})"), {B, "shape.radius", "finite", "1e999"}},
      {"radius as a boolean", shaped(R"({"type": "sphere", "radius": true})"), {B, "shape.radius", "must be a number"}},
      {"missing radius", shaped(R"({"type": "sphere"})"), {B, "shape.radius", "missing"}},
      {"key of another shape type", shaped(R"({"type": "sphere", "radius": 1, "length": 2})"),
       {B, "shape", "unknown key \"length\"", "sphere"}},
      {"box size of 2", shaped(R"({"type": "box", "size": [1, 1]})"), {B, "shape.size", "3 numbers"}},
      {"box negative edge", shaped(R"({"type": "box", "size": [1, -1, 1]})"), {B, "shape.size[1]", "> 0"}},
      {"cylinder zero length", shaped(R"({"type": "cylinder", "radius": 1, "length": 0})"), {B, "shape.length", "> 0"}},
      {"cylinder missing length", shaped(R"({"type": "cylinder", "radius": 1})"), {B, "shape.length", "missing"}},
      {"capsule negative length", shaped(R"({"type": "capsule", "radius": 1, "length": -1})"), {B, "shape.length", ">= 0"}},
      {"capsule negative radius", shaped(R"({"type": "capsule", "radius": -2, "length": 1})"), {B, "shape.radius", "> 0"}},
      {"convex no points", shaped(R"({"type": "convex", "points": []})"), {B, "shape.points", "non-empty"}},
      {"convex point of 2", shaped(R"({"type": "convex", "points": [[0, 0, 0], [1, 1]]})"), {B, "shape.points[1]", "3 numbers"}},
      {"convex point overflows", shaped(R"({"type": "convex", "points": [[0, 0, 0], [1, -1e400, 0]]})"),
       {B, "shape.points[1][1]", "finite", "-1e400"}},
      {"mesh index out of range", shaped(R"({"type": "mesh", "vertices": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0, 1, 3]]})"),
       {B, "shape.triangles[0][2]", "[0, 3)", "got 3"}},
      {"mesh negative index", shaped(R"({"type": "mesh", "vertices": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0, -1, 2]]})"),
       {B, "shape.triangles[0][1]", "got -1"}},
      {"mesh fractional index", shaped(R"({"type": "mesh", "vertices": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0, 1.5, 2]]})"),
       {B, "shape.triangles[0][1]", "integer"}},
      {"mesh huge index", shaped(R"({"type": "mesh", "vertices": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0, 1, 18446744073709551615]]})"),
       {B, "shape.triangles[0][2]", "got 18446744073709551615"}},
      {"mesh triangle of 4", shaped(R"({"type": "mesh", "vertices": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0, 1, 2, 0]]})"),
       {B, "shape.triangles[0]", "3 vertex indices"}},
      {"mesh no triangles", shaped(R"({"type": "mesh", "vertices": [[0,0,0],[1,0,0],[0,1,0]], "triangles": []})"),
       {B, "shape.triangles", "non-empty"}},
      {"mesh no vertices", shaped(R"({"type": "mesh", "vertices": [], "triangles": [[0, 1, 2]]})"), {B, "shape.vertices", "non-empty"}},
      // Poses and velocities.
      {"missing position", b(kShape), {B, "position", "missing"}},
      {"position of 2", b(std::string(kShape) + R"(, "position": [0, 0])"), {B, "position", "3 numbers"}},
      {"position element a string", b(std::string(kShape) + R"(, "position": [0, "1", 0])"), {B, "position[1]", "number"}},
      {"position overflows", b(std::string(kShape) + R"(, "position": [0, 0, 1e999])"), {B, "position[2]", "finite", "1e999"}},
      {"zero quaternion", b(std::string(kShape) + R"(, "position": [0, 0, 0], "orientation": [0, 0, 0, 0])"),
       {B, "orientation", "non-zero quaternion"}},
      {"tiny quaternion", b(std::string(kShape) + R"(, "position": [0, 0, 0], "orientation": [1e-12, 0, 0, 0])"),
       {B, "orientation", "non-zero quaternion"}},
      {"quaternion of 3", b(std::string(kShape) + R"(, "position": [0, 0, 0], "orientation": [0, 0, 1])"),
       {B, "orientation", "4 numbers"}},
      {"linear velocity null", b(std::string(kShape) + R"(, "position": [0, 0, 0], "linear_velocity": null)"),
       {B, "linear_velocity", "3 numbers"}},
      {"angular velocity overflows", b(std::string(kShape) + R"(, "position": [0, 0, 0], "angular_velocity": [0, 1e309, 0])"),
       {B, "angular_velocity[1]", "finite"}},
      {"id with a newline and quote", second(std::string(R"({"id": "x\ny\"", )") + kShape + R"(, "position": [0, 0]})"),
       {"body \"x\\ny\\\"\" (index 1)", "position"}},
  };
}

TEST(SceneIo, EveryBadInputNamesTheBodyAndTheField) {
  for (const BadCase& c : badCases()) {
    try {
      parseScene(c.text);
      ADD_FAILURE() << c.name << ": accepted";
    } catch (const InvalidArgument& e) {
      const std::string msg = e.what();
      for (const std::string& needle : c.needles) {
        EXPECT_NE(msg.find(needle), std::string::npos) << c.name << ": \"" << needle << "\" not in: " << msg;
      }
      EXPECT_EQ(msg.find('\n'), std::string::npos) << c.name << ": not one line: " << msg;
    } catch (const std::exception& e) {
      ADD_FAILURE() << c.name << ": wrong exception type: " << e.what();
    }
  }
}

TEST(SceneIo, TheBodyIsNamedByIdWhenItComesAfterTheBadField) {
  // The parser meets the overflow before the id: the message names the body by index.
  try {
    parseScene(R"({"horizon": 1, "bodies": [{"shape": {"type": "sphere", "radius": 1e999}, "id": "late", "position": [0,0,0]}]})");
    FAIL() << "accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("body at index 0: shape.radius"), std::string::npos) << e.what();
  }
  // Semantic checks run after parsing: then the id is known.
  try {
    parseScene(R"({"horizon": 1, "bodies": [{"shape": {"type": "sphere", "radius": -1e300}, "id": "late", "position": [0,0,0]}]})");
    FAIL() << "accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("body \"late\" (index 0): shape.radius"), std::string::npos) << e.what();
  }
}

TEST(SceneIo, ReadSceneFile) {
  char path[] = "/tmp/vadop_scene_io_XXXXXX";
  const int fd = mkstemp(path);
  ASSERT_GE(fd, 0);
  const std::string text = R"({"horizon": 3, "bodies": [{"id": "only", "shape": {"type": "sphere", "radius": 2}, "position": [0,0,0]}]})";
  ASSERT_EQ(write(fd, text.data(), text.size()), static_cast<ssize_t>(text.size()));
  close(fd);
  const Scene s = readSceneFile(path);
  EXPECT_EQ(s.horizon, 3.0);
  ASSERT_EQ(s.bodies.size(), 1u);
  EXPECT_EQ(s.bodies[0].shape.radius, 2.0);
  std::remove(path);
  try {
    readSceneFile(path);
    FAIL() << "read a removed file";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

TEST(SceneIo, ImpactLinesHaveAFixedLayoutAndRoundTrip) {
  WorldImpact w;
  w.a = "left";
  w.b = "ri\"ght";
  w.impact.hit = true;
  w.impact.time = 0.1;
  w.impact.point = Eigen::Vector3d(1.5, -0.0, 2);
  w.impact.normal = Eigen::Vector3d(1, 0, -0.0);
  EXPECT_EQ(impactToJson(w),
            R"({"a":"left","b":"ri\"ght","time":0.1,"point":[1.5,0.0,2.0],"normal":[1.0,0.0,0.0]})");
  EXPECT_EQ(impactsToJsonLines({w, w}), impactToJson(w) + "\n" + impactToJson(w) + "\n");
  // Shortest round-trip form: every double reads back exactly.
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int i = 0; i < 1000; ++i) {
    const double x = u(rng) * std::pow(10.0, static_cast<int>(rng() % 40) - 20);
    w.impact.time = x;
    const std::string line = impactToJson(w);
    const size_t at = line.find("\"time\":") + 7;
    EXPECT_EQ(std::strtod(line.c_str() + at, nullptr), x) << line;
  }
}

#ifdef VADOP_FUZZ_CORPUS_DIR
TEST(SceneIo, FuzzSeedCorpusIsValid) {
  DIR* dir = opendir(VADOP_FUZZ_CORPUS_DIR);
  ASSERT_NE(dir, nullptr) << VADOP_FUZZ_CORPUS_DIR;
  int files = 0;
  while (const dirent* e = readdir(dir)) {
    const std::string name = e->d_name;
    if (name.size() < 5 || name.substr(name.size() - 5) != ".json") continue;
    ++files;
    const Scene s = readSceneFile(std::string(VADOP_FUZZ_CORPUS_DIR) + "/" + name);
    World w;
    addToWorld(s, w);
    EXPECT_NO_THROW(w.predict(0.0, s.horizon)) << name;
  }
  closedir(dir);
  EXPECT_GE(files, 3);
}
#endif

}  // namespace
}  // namespace vadop
