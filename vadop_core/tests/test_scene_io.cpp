// Scene reading (JSON -> shapes and motions) and impact formatting (JSON lines):
//  - every shape type is read with URDF conventions; defaults for orientation and velocities;
//  - every kind of bad input throws vadop::InvalidArgument with a one-line message that names
//    the body (id and index, or index) and the field;
//  - impact lines have a fixed key order and numbers that read back to the same doubles;
//    undecided pairs print as lines of their own, merged with the contacts by time;
//  - limits (issue 13): nesting depth, input size, NUL bytes, bounded messages, the ranges of
//    error.h, quaternions normalised scale-safely;
//  - the fuzz seed corpus consists of valid scenes, and of bad_*.json seeds that are rejected.
#include "vadop/error.h"
#include "vadop/scene_io.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <dirent.h>
#include <unistd.h>
#include <fstream>
#include <random>
#include <sstream>
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
      {"negative zero quaternion", b(std::string(kShape) + R"(, "position": [0, 0, 0], "orientation": [-0.0, 0, -0.0, 0])"),
       {B, "orientation", "non-zero quaternion"}},
      {"quaternion of 3", b(std::string(kShape) + R"(, "position": [0, 0, 0], "orientation": [0, 0, 1])"),
       {B, "orientation", "4 numbers"}},
      {"linear velocity null", b(std::string(kShape) + R"(, "position": [0, 0, 0], "linear_velocity": null)"),
       {B, "linear_velocity", "3 numbers"}},
      {"angular velocity overflows", b(std::string(kShape) + R"(, "position": [0, 0, 0], "angular_velocity": [0, 1e309, 0])"),
       {B, "angular_velocity[1]", "finite"}},
      {"id with a newline and quote", second(std::string(R"({"id": "x\ny\"", )") + kShape + R"(, "position": [0, 0]})"),
       {"body \"x\\ny\\\"\" (index 1)", "position"}},
      // Limits (issue 13).
      {"trailing NUL byte", std::string(R"({"horizon": 1, "bodies": []})") + '\0' + "x", {"malformed JSON at byte 29", "NUL byte"}},
      {"NUL byte in a value", std::string(R"({"horizon": 1, "bodies": [)") + '\0' + "]}", {"body at index 0", "byte 27", "NUL byte"}},
      {"NUL byte in a string", second(std::string(R"({"id": "a)") + '\0' + "\"}"), {"index 1", "id", "NUL"}},
      {"nested 65 deep", R"({"horizon": 1, "bodies": [{"id": "a", "shape": )" + std::string(62, '[') + std::string(62, ']') + "}]}",
       {"body \"a\" (index 0): shape[0][0]", "nested deeper than 64 levels"}},
      {"position beyond kMaxCoordinate", b(std::string(kShape) + R"(, "position": [0, 1.0000001e7, 0])"),
       {B, "position[1] = ", "is beyond"}},
      {"radius beyond kMaxSize", shaped(R"({"type": "sphere", "radius": 1.0000001e5})"), {B, "shape.radius = ", "is beyond"}},
      {"box edge beyond kMaxSize", shaped(R"({"type": "box", "size": [1, 1, 2e5]})"), {B, "shape.size[2] = ", "is beyond"}},
      {"cylinder length beyond kMaxSize", shaped(R"({"type": "cylinder", "radius": 1, "length": 2e5})"), {B, "shape.length = "}},
      {"cylinder radius beyond kMaxSize", shaped(R"({"type": "cylinder", "radius": 2e5, "length": 1})"), {B, "shape.radius = "}},
      {"capsule length beyond kMaxSize", shaped(R"({"type": "capsule", "radius": 1, "length": 2e5})"), {B, "shape.length = "}},
      {"convex coordinate beyond kMaxSize", shaped(R"({"type": "convex", "points": [[0, 0, 0], [-2e5, 0, 0]]})"),
       {B, "shape.points[1][0] = "}},
      {"convex point beyond kMaxSize by its norm", shaped(R"({"type": "convex", "points": [[6e4, 6e4, 6e4]]})"),
       {B, "|shape.points[0]| = "}},
      {"mesh vertex beyond kMaxSize", shaped(R"({"type": "mesh", "vertices": [[0,0,0],[1,0,0],[0,1,3e5]], "triangles": [[0, 1, 2]]})"),
       {B, "shape.vertices[2][2] = "}},
      {"linear velocity beyond kMaxLinearSpeed", b(std::string(kShape) + R"(, "position": [0, 0, 0], "linear_velocity": [0, 0, -2e4])"),
       {B, "linear_velocity[2] = ", "m/s"}},
      {"linear speed beyond kMaxLinearSpeed", b(std::string(kShape) + R"(, "position": [0, 0, 0], "linear_velocity": [6e3, 6e3, 6e3])"),
       {B, "|linear_velocity| = ", "m/s"}},
      {"angular velocity beyond kMaxAngularSpeed", b(std::string(kShape) + R"(, "position": [0, 0, 0], "angular_velocity": [2e4, 0, 0])"),
       {B, "angular_velocity[0] = ", "rad/s"}},
      {"angular speed beyond kMaxAngularSpeed", b(std::string(kShape) + R"(, "position": [0, 0, 0], "angular_velocity": [0, 8e3, 8e3])"),
       {B, "|angular_velocity| = ", "rad/s"}},
      {"horizon beyond kMaxTime", R"({"horizon": 1.0000001e7, "bodies": []})", {"horizon = ", "is beyond", " s"}},
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
      EXPECT_LE(msg.size(), kMaxMessageBytes) << c.name << ": " << msg;
    } catch (const std::exception& e) {
      ADD_FAILURE() << c.name << ": wrong exception type: " << e.what();
    }
  }
}

std::string repeat(const std::string& s, size_t n) {
  std::string out;
  for (size_t i = 0; i < n; ++i) out += s;
  return out;
}

std::string rejection(const std::string& text) {
  try {
    parseScene(text);
  } catch (const InvalidArgument& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(SceneIo, NestingIsLimitedToKMaxSceneDepthLevels) {
  static_assert(kMaxSceneDepth == 64, "the README and the messages say 64");
  // The scene object is level 1: a horizon nested in 63 arrays reaches level 64 and is read (and
  // then rejected as not a number); one more level is refused by the parser.
  auto horizon = [](size_t levels) {
    return R"({"horizon": )" + std::string(levels, '[') + std::string(levels, ']') + R"(, "bodies": []})";
  };
  EXPECT_NE(rejection(horizon(63)).find("horizon must be a number, got array"), std::string::npos) << rejection(horizon(63));
  EXPECT_EQ(rejection(horizon(64)).rfind("horizon[0][0]", 0), 0u) << rejection(horizon(64));
  EXPECT_NE(rejection(horizon(64)).find("nested deeper than 64 levels"), std::string::npos);
  // A scene at the top level nested too deep, and 80,000 levels of objects: no recursion over them.
  EXPECT_EQ(rejection(std::string(100, '[')).rfind("[0][0]", 0), 0u) << rejection(std::string(100, '['));
  const std::string deep = repeat(R"({"a": )", 80000) + "1" + std::string(80000, '}');
  EXPECT_NE(rejection(deep).find("a.a.a"), std::string::npos);
  EXPECT_NE(rejection(deep).find("nested deeper than 64 levels"), std::string::npos) << rejection(deep);
  EXPECT_LE(rejection(deep).size(), kMaxMessageBytes);
}

TEST(SceneIo, TheWholeTextIsParsedPastANulByte) {
  const std::string scene = R"({"horizon": 2, "bodies": []})";
  EXPECT_EQ(parseScene(scene + " \n\t").horizon, 2.0);
  for (const std::string& tail : {std::string(1, '\0'), std::string("\0garbage", 8), std::string(" \0 ", 3)}) {
    const std::string msg = rejection(scene + tail);
    EXPECT_NE(msg.find("NUL byte"), std::string::npos) << msg;
  }
}

TEST(SceneIo, MessagesQuoteAndShortenInput) {
  // messageQuote: a JSON string literal, its content cut at kMaxQuotedChars with "...".
  EXPECT_EQ(messageQuote("robot"), "\"robot\"");
  EXPECT_EQ(messageQuote("a\"b\n"), "\"a\\\"b\\n\"");
  EXPECT_EQ(messageQuote(std::string(kMaxQuotedChars, 'x')), "\"" + std::string(kMaxQuotedChars, 'x') + "\"");
  EXPECT_EQ(messageQuote(std::string(kMaxQuotedChars + 1, 'x')), "\"" + std::string(kMaxQuotedChars, 'x') + "...\"");
  EXPECT_EQ(messageQuote(std::string(1 << 20, 'y')), "\"" + std::string(kMaxQuotedChars, 'y') + "...\"");
  // Escapes are never cut in half: 40 / 6 = 6 whole \u0001 escapes.
  EXPECT_EQ(messageQuote(std::string(100, '\1')), "\"" + repeat("\\u0001", 6) + "...\"");
  EXPECT_EQ(messageQuote("caf\xc3\xa9"), "\"caf\\u00e9\"");
  // boundedMessage: one printable line of at most max_bytes.
  EXPECT_EQ(boundedMessage("a\nb\x01\xff"), "a b ?");
  EXPECT_EQ(boundedMessage(std::string(1000, 'z')), std::string(kMaxMessageBytes - 3, 'z') + "...");
  EXPECT_EQ(boundedMessage(std::string(kMaxMessageBytes, 'z')), std::string(kMaxMessageBytes, 'z'));

  // Megabyte ids, keys, values and paths give messages of at most kMaxMessageBytes.
  const std::string mb(1 << 20, 'x');
  const std::string sphere = R"("shape": {"type": "sphere", "radius": 1})";
  std::string keys = R"({"horizon": )";
  for (int i = 0; i < 60; ++i) keys += "{\"" + std::string(10000, static_cast<char>('a' + i % 26)) + "\": ";
  const std::vector<std::pair<std::string, std::string>> cases = {  // text, expected part
      {R"({"horizon": 1, "bodies": [{"id": ")" + mb + R"(", "shape": {"type": "sphere", "radius": -1}, "position": [0, 0, 0]}]})",
       "body \"" + std::string(kMaxQuotedChars, 'x') + "...\" (index 0): shape.radius must be finite and > 0, got -1"},
      {R"({"horizon": 1, "bodies": [{"id": "a", )" + sphere + R"(, "position": [0, 0, 0], ")" + mb + R"(": 1}]})",
       "unknown key \"xxxxxxxx"},
      {R"({"horizon": ")" + mb + R"(", "bodies": []})", "horizon must be a number, got string \"xxx"},
      {R"({"horizon": [)" + repeat("[1, 2, 3],", 100000) + R"(1], "bodies": []})", "got array [[1,2,3],[1,2,3],"},
      {R"({"horizon": {)" + repeat(R"("k": 1, )", 1) + R"("m": ")" + mb + R"("}, "bodies": []})", "got object {\"k\":1,\"m\":\"xx"},
      {R"({"horizon": 1)" + std::string(1 << 20, '0') + R"(, "bodies": []})", "horizon must be finite, got 10000"},
      {R"({"horizon": 1, "bodies": [{"id": ")" + mb, "body at index 0: id: malformed JSON"},
      {keys, "horizon."},
      {R"({"horizon": 1, "bodies": [)" + std::string(3000000, '['), "bodies[0][0]"},
      {R"({"horizon": 1, "bodies": [{"id": "a", )" + sphere + R"(, "position": [0, 0, 0], "orientation": [)" + mb + "]}]}",
       "body \"a\" (index 0): orientation"},
  };
  for (const auto& [text, part] : cases) {
    const std::string msg = rejection(text);
    EXPECT_LE(msg.size(), kMaxMessageBytes) << msg.substr(0, 1000);
    EXPECT_EQ(msg.find('\n'), std::string::npos);
    EXPECT_NE(msg.find(part), std::string::npos) << "\"" << part << "\" not in: " << msg.substr(0, 1000);
  }
}

TEST(SceneIo, QuaternionsNormaliseScaleSafely) {
  // [0, 0, 1e200, 1e200] overflows and [0, 0, 1e-200, 1e-200] underflows a plain norm: both are
  // the quarter turn about z, as are the other scales; only a real zero is rejected.
  auto turned = [](const std::string& q) {
    return parseScene(oneBody(R"({"id": "q", "shape": {"type": "sphere", "radius": 1}, "position": [0, 0, 0], "orientation": )" +
                              q + "}"))
        .bodies[0]
        .motion.orientation;
  };
  const Eigen::Quaterniond ref = turned("[0, 0, 1, 1]");
  EXPECT_NEAR((ref * Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitY()).norm(), 0.0, 1e-15);
  for (const char* q : {"[0, 0, 1e200, 1e200]", "[0, 0, 1e-200, 1e-200]", "[0, 0, 5e-324, 5e-324]",
                        "[0, 0, 1.7976931348623157e308, 1.7976931348623157e308]", "[0, 0, 1e-12, 1e-12]"}) {
    const Eigen::Quaterniond r = turned(q);
    EXPECT_NEAR(r.norm(), 1.0, 1e-15) << q;
    EXPECT_NEAR((r.coeffs() - ref.coeffs()).norm(), 0.0, 1e-15) << q;
  }
  EXPECT_NEAR(std::abs(turned("[1e-12, 0, 0, 0]").x()), 1.0, 1e-15);
}

TEST(SceneIo, ValuesAtTheEdgeOfTheRangeAreRead) {
  const Scene s = parseScene(R"({"horizon": 1e7, "bodies": [
      {"id": "a", "shape": {"type": "sphere", "radius": 1e5}, "position": [1e7, -1e7, 1e7],
       "linear_velocity": [1e4, 0, 0], "angular_velocity": [0, -1e4, 0]},
      {"id": "b", "shape": {"type": "box", "size": [1e5, 1e5, 1e5]}, "position": [0, 0, 0]},
      {"id": "c", "shape": {"type": "capsule", "radius": 1e5, "length": 1e5}, "position": [0, 0, 0]},
      {"id": "d", "shape": {"type": "convex", "points": [[1e5, 0, 0], [0, -1e5, 0], [0, 0, 1e5]]}, "position": [0, 0, 0],
       "linear_velocity": [6e3, 0, 8e3]}]})");
  EXPECT_EQ(s.horizon, kMaxTime);
  EXPECT_EQ(s.bodies[0].motion.position.x(), kMaxCoordinate);
  EXPECT_EQ(s.bodies[0].shape.radius, kMaxSize);
  EXPECT_EQ(s.bodies[0].motion.linear_velocity.x(), kMaxLinearSpeed);
  EXPECT_EQ(s.bodies[0].motion.angular_velocity.y(), -kMaxAngularSpeed);
  EXPECT_EQ(s.bodies[3].motion.linear_velocity.norm(), kMaxLinearSpeed);
}

TEST(SceneIo, ReadSceneStopsOneByteAfterTheSizeLimit) {
  // A stream that never ends: readScene must stop after kMaxSceneBytes + 1 bytes.
  struct Endless : std::streambuf {
    size_t served = 0;
    char buf[4096];
    int_type underflow() override {
      std::fill(std::begin(buf), std::end(buf), ' ');
      served += sizeof buf;
      setg(buf, buf, buf + sizeof buf);
      return traits_type::to_int_type(buf[0]);
    }
  } endless;
  std::istream in(&endless);
  try {
    readScene(in, "the endless stream");
    FAIL() << "accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_EQ(std::string(e.what()), "the endless stream is larger than 64 MiB (67108864 bytes), the limit of a scene");
  }
  EXPECT_LE(endless.served, kMaxSceneBytes + 2 * sizeof endless.buf);
  // Exactly kMaxSceneBytes is read.
  std::string text = R"({"horizon": 3, "bodies": []})";
  text.resize(kMaxSceneBytes, ' ');
  std::istringstream full(text);
  EXPECT_EQ(readScene(full, "full").horizon, 3.0);
  text += ' ';
  std::istringstream over(text);
  EXPECT_THROW(readScene(over, "over"), InvalidArgument);
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

TEST(SceneIo, UndecidedPairsPrintAsLinesOfTheirOwnInTimeOrder) {
  auto pair = [](const char* a, const char* b, uint64_t ka, uint64_t kb, double t, bool undecided) {
    Contact w;
    w.a = a;
    w.b = b;
    w.a_key = ka;
    w.b_key = kb;
    w.impact.hit = !undecided;
    w.impact.undecided = undecided;
    w.impact.time = t;
    return w;
  };
  const Contact u = pair("p", "q\"", 0, 5, 0.25, true);
  EXPECT_EQ(undecidedToJson(u), R"({"a":"p","b":"q\"","undecided_after":0.25})");
  EXPECT_EQ(undecidedToJson(pair("p", "q", 0, 5, -0.0, true)), R"({"a":"p","b":"q","undecided_after":0.0})");
  // Merged with the contacts by time, then the input order of a, then of b.
  const std::vector<Contact> contacts = {pair("a", "b", 0, 1, 0.0, false), pair("c", "d", 2, 3, 0.25, false),
                                             pair("a", "d", 0, 3, 0.5, false)};
  const std::vector<Contact> undecided = {pair("a", "c", 0, 2, 0.25, true), pair("b", "c", 1, 2, 0.25, true),
                                              pair("c", "e", 2, 4, 0.75, true)};
  EXPECT_EQ(predictionToJsonLines(contacts, undecided),
            impactToJson(contacts[0]) + "\n" + undecidedToJson(undecided[0]) + "\n" + undecidedToJson(undecided[1]) + "\n" +
                impactToJson(contacts[1]) + "\n" + impactToJson(contacts[2]) + "\n" + undecidedToJson(undecided[2]) + "\n");
  EXPECT_EQ(predictionToJsonLines(contacts, {}), impactsToJsonLines(contacts));
  EXPECT_EQ(predictionToJsonLines({}, {}), "");

  // From a World whose narrow phase has a budget of one step: boxes closing in are undecided,
  // never contacts; the spheres (closed form) still touch.
  const Scene s = parseScene(R"({"horizon": 2, "bodies": [
      {"id": "box1", "shape": {"type": "box", "size": [1, 1, 1]}, "position": [0, 0, 0], "linear_velocity": [1, 0, 0]},
      {"id": "ball1", "shape": {"type": "sphere", "radius": 0.5}, "position": [0, 5, 0], "linear_velocity": [1, 0, 0]},
      {"id": "box2", "shape": {"type": "box", "size": [1, 1, 1]}, "position": [3, 0, 0], "linear_velocity": [-1, 0, 0]},
      {"id": "ball2", "shape": {"type": "sphere", "radius": 0.5}, "position": [0, 6.5, 0], "linear_velocity": [1, -1, 0]}]})");
  WorldConfig config;
  config.toi.max_iterations = 1;
  World world(config);
  addToWorld(s, world);
  const std::vector<Contact> found = world.predict(0.0, s.horizon);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0].a + found[0].b, "ball1ball2");
  ASSERT_EQ(world.lastUndecided().size(), 1u);
  const Contact& open = world.lastUndecided()[0];
  EXPECT_EQ(open.a + open.b, "box1box2");
  EXPECT_TRUE(open.impact.undecided);
  EXPECT_LT(open.impact.time, 1.0);  // certified clear only before the contact at t = 1
  const std::string out = predictionToJsonLines(found, world.lastUndecided());
  const std::string open_line = R"({"a":"box1","b":"box2","undecided_after":)";
  EXPECT_NE(out.find(open_line), std::string::npos) << out;
  EXPECT_EQ(std::count(out.begin(), out.end(), '\n'), 2) << out;
}

TEST(SceneIo, ImpactLinesHaveAFixedLayoutAndRoundTrip) {
  Contact w;
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
  int files = 0, bad = 0;
  while (const dirent* e = readdir(dir)) {
    const std::string name = e->d_name;
    if (name.size() < 5 || name.substr(name.size() - 5) != ".json") continue;
    ++files;
    const std::string path = std::string(VADOP_FUZZ_CORPUS_DIR) + "/" + name;
    if (name.rfind("bad_", 0) == 0) {  // seeds for the error paths: rejected, with a bounded one-line message
      ++bad;
      try {
        readSceneFile(path);
        ADD_FAILURE() << name << ": accepted";
      } catch (const InvalidArgument& e) {
        EXPECT_LE(std::string(e.what()).size(), kMaxMessageBytes) << name;
        EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << name;
      }
      continue;
    }
    const Scene s = readSceneFile(path);
    World w;
    addToWorld(s, w);
    EXPECT_NO_THROW(w.predict(0.0, s.horizon)) << name;
  }
  closedir(dir);
  EXPECT_GE(files - bad, 3);
}
#endif

}  // namespace
}  // namespace vadop
