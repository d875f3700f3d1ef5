#include "vadop/scene_io.h"

#include "vadop/error.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <istream>
#include <iterator>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <unordered_map>
#include <utility>

namespace vadop {
namespace {

using json = nlohmann::json;

// ------------------------------------------------------------------------------ text helpers

std::string quoted(const std::string& s) { return messageQuote(s); }

// At most this many characters of a value in a "got ..." text, and of a field path.
constexpr size_t kMaxBriefChars = 60;
constexpr size_t kMaxPathChars = 100;

// Compact one-line JSON text of v, appended to `out`, stopping once `out` holds more than
// `limit` characters: a huge value is never serialized whole. Strings and keys are quoted by
// messageQuote. Recursion is bounded by the parser's depth limit (kMaxSceneDepth).
void appendBrief(const json& v, std::string& out, size_t limit) {
  if (out.size() > limit) return;
  switch (v.type()) {
    case json::value_t::array: {
      out += '[';
      bool first = true;
      for (const json& e : v) {
        if (out.size() > limit) return;
        if (!first) out += ',';
        first = false;
        appendBrief(e, out, limit);
      }
      out += ']';
      return;
    }
    case json::value_t::object: {
      out += '{';
      bool first = true;
      for (const auto& kv : v.items()) {
        if (out.size() > limit) return;
        if (!first) out += ',';
        first = false;
        out += messageQuote(kv.key());
        out += ':';
        appendBrief(kv.value(), out, limit);
      }
      out += '}';
      return;
    }
    case json::value_t::string: out += messageQuote(v.get_ref<const std::string&>()); return;
    default: out += v.dump(); return;  // a number, boolean or null: short
  }
}

// "got ..." text: the value itself, shortened.
std::string brief(const json& v) {
  std::string s;
  appendBrief(v, s, kMaxBriefChars);
  if (s.size() > kMaxBriefChars) s = s.substr(0, kMaxBriefChars - 3) + "...";
  switch (v.type()) {
    case json::value_t::string: return "string " + s;
    case json::value_t::array: return "array " + s;
    case json::value_t::object: return "object " + s;
    case json::value_t::boolean: return "boolean " + s;
    case json::value_t::null: return "null";
    default: return s;  // a number
  }
}

std::string bodyLabel(size_t index, const std::string* id) {
  if (id) return "body " + quoted(*id) + " (index " + std::to_string(index) + ")";
  return "body at index " + std::to_string(index);
}

// One printable, bounded line (a parser message can quote raw input).
std::string oneLine(const std::string& s) { return boundedMessage(s); }

// ------------------------------------------------------------------ parsing with a location

// Tracks where the parser is (the path of keys and array indices), so that errors raised by
// the parser itself (syntax, number overflow) and duplicate keys can name body and field, and
// records the body ids seen so far for those messages.
// A key as a path component: as is when it is a plain name, else JSON-quoted (escaped, and
// shortened when long), so that the path stays on one line and readable.
std::string pathKey(const std::string& key) {
  const bool plain = !key.empty() && key.size() <= kMaxQuotedChars && std::all_of(key.begin(), key.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
  });
  return plain ? key : quoted(key);
}

// A field path of at most about kMaxPathChars characters: when longer, its first and last
// components with "..." between them.
std::string joinPath(const std::vector<std::string>& parts) {
  std::string all;
  for (const std::string& p : parts) all += p;
  if (all.size() <= kMaxPathChars) return all;
  std::string head, tail;
  size_t i = 0, j = parts.size();
  while (i < j && head.size() + parts[i].size() <= kMaxPathChars / 2) head += parts[i++];
  while (j > i && tail.size() + parts[j - 1].size() <= kMaxPathChars / 2) tail = parts[--j] + tail;
  if (head.empty()) head = parts[0].substr(0, kMaxPathChars / 2);  // one long component
  return head + "..." + tail;
}

class Locator {
 public:
  // Thrown from the parser callback: stops the parse with a message.
  struct Stop {
    std::string message;
  };

  bool operator()(int /*depth*/, json::parse_event_t event, json& parsed) {
    switch (event) {
      case json::parse_event_t::object_start:
      case json::parse_event_t::array_start:
        // Checked before the level is opened: nothing deeper is ever built or visited.
        if (frames_.size() >= static_cast<size_t>(kMaxSceneDepth)) {
          const std::string at = where();
          throw Stop{(at.empty() ? std::string("scene") : at) + ": arrays and objects nested deeper than " +
                     std::to_string(kMaxSceneDepth) + " levels (the limit; a scene needs 6)"};
        }
        frames_.push_back(Frame{event == json::parse_event_t::array_start, 0, {}, {}});
        break;
      case json::parse_event_t::key: {
        Frame& f = frames_.back();
        std::string k = parsed.get<std::string>();
        if (!f.keys.insert(k).second) {
          f.key = std::move(k);
          throw Stop{where() + " is given twice (duplicate key)"};
        }
        f.key = std::move(k);
        break;
      }
      case json::parse_event_t::value:
        if (parsed.is_string() && inBody() && frames_.size() == 3 && frames_[2].key == "id") {
          ids_[frames_[1].index] = parsed.get<std::string>();
        }
        completed();
        break;
      case json::parse_event_t::object_end:
      case json::parse_event_t::array_end:
        frames_.pop_back();
        completed();
        break;
    }
    return true;
  }

  // "body "b" (index 1): shape.radius", "horizon", "body at index 2", or "" at the top level.
  std::string where() const {
    std::string label;
    std::vector<std::string> field;
    size_t first = 0;
    if (inBody() || (frames_.size() == 2 && isBodiesArray())) {
      const size_t index = frames_[1].index;
      const auto id = ids_.find(index);
      label = bodyLabel(index, id == ids_.end() ? nullptr : &id->second);
      first = 2;
    }
    for (size_t i = first; i < frames_.size(); ++i) {
      const Frame& f = frames_[i];
      if (f.array) {
        field.push_back("[" + std::to_string(f.index) + "]");
      } else if (!f.key.empty() || !f.keys.empty()) {
        field.push_back((field.empty() ? "" : ".") + pathKey(f.key));
      }
    }
    const std::string path = joinPath(field);
    if (label.empty()) return path;
    return path.empty() ? label : label + ": " + path;
  }

 private:
  struct Frame {
    bool array;
    size_t index;                // array: the element being parsed
    std::string key;             // object: the key being parsed
    std::set<std::string> keys;  // object: the keys seen
  };
  bool isBodiesArray() const { return !frames_[0].array && frames_[0].key == "bodies" && frames_[1].array; }
  bool inBody() const { return frames_.size() >= 3 && isBodiesArray() && !frames_[2].array; }
  void completed() {
    if (!frames_.empty() && frames_.back().array) ++frames_.back().index;
  }

  std::vector<Frame> frames_;
  std::map<size_t, std::string> ids_;
};

json parseJson(const std::string& text) {
  Locator locator;
  // nlohmann's lexer takes a NUL byte outside a string for the end of the input (inside a
  // string it is an error anyway), so text after it would be ignored: the text is parsed with
  // its full length, and a NUL byte where the parser stopped is reported as such.
  const size_t nul = text.find('\0');
  json root;
  // nlohmann's message without its "[json.exception...] parse error at " prefix, after the location.
  auto malformed = [&locator](const json::exception& e) {
    std::string msg = e.what();
    const std::string prefix = "parse error at ";
    const size_t p = msg.find(prefix);
    msg = p != std::string::npos ? msg.substr(p + prefix.size()) : msg.substr(msg.find(']') + 1);
    const std::string at = locator.where();
    throw InvalidArgument(oneLine((at.empty() ? std::string() : at + ": ") + "malformed JSON at " + msg));
  };
  try {
    root = json::parse(text.begin(), text.end(), std::ref(locator));
  } catch (const Locator::Stop& e) {
    throw InvalidArgument(oneLine(e.message));
  } catch (const json::parse_error& e) {
    if (nul != std::string::npos && e.byte >= nul + 1) {
      const std::string at = locator.where();
      throw InvalidArgument(oneLine((at.empty() ? std::string() : at + ": ") + "malformed JSON at byte " +
                                    std::to_string(nul + 1) + ": a NUL byte (not allowed in JSON text)"));
    }
    malformed(e);
  } catch (const json::out_of_range& e) {
    // 406: a number that overflows a double (JSON itself has no NaN or Inf).
    std::string token = e.what();
    const size_t open = token.find('\''), close = token.rfind('\'');
    token = open != std::string::npos && close > open ? token.substr(open + 1, close - open - 1) : "a number";
    if (token.size() > kMaxBriefChars) token = token.substr(0, kMaxBriefChars - 3) + "...";
    const std::string at = locator.where();
    throw InvalidArgument(oneLine((at.empty() ? "scene" : at) + " must be finite, got " + token +
                                  " (out of the range of a double)"));
  } catch (const json::exception& e) {
    malformed(e);
  }
  if (nul != std::string::npos) {  // the parse ended at the NUL byte: what follows is not JSON
    throw InvalidArgument("malformed JSON at byte " + std::to_string(nul + 1) +
                          ": a NUL byte after the scene (trailing text)");
  }
  return root;
}

// ----------------------------------------------------------------------- semantic validation

class Checker {
 public:
  explicit Checker(std::string label) : label_(std::move(label)) {}

  [[noreturn]] void fail(const std::string& field, const std::string& what) const {
    throw InvalidArgument(oneLine(label_.empty() ? field + " " + what : label_ + ": " + field + " " + what));
  }
  [[noreturn]] void failPlain(const std::string& what) const {
    throw InvalidArgument(oneLine(label_.empty() ? what : label_ + ": " + what));
  }

  void onlyKeys(const json& obj, const std::vector<const char*>& allowed, const std::string& where,
                const std::string& kind = "") const {
    for (const auto& kv : obj.items()) {
      if (std::find_if(allowed.begin(), allowed.end(), [&](const char* a) { return kv.key() == a; }) ==
          allowed.end()) {
        std::string list;
        for (const char* a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
        const std::string what = "unknown key " + quoted(kv.key()) + kind + " (allowed: " + list + ")";
        if (where.empty()) failPlain(what);
        fail(where + ":", what);
      }
    }
  }

  const json& required(const json& obj, const char* key, const std::string& field) const {
    const auto it = obj.find(key);
    if (it == obj.end()) fail(field, "is missing");
    return *it;
  }

  double number(const json& v, const std::string& field) const {
    if (!v.is_number()) fail(field, "must be a number, got " + brief(v));
    const double x = v.get<double>();
    if (!std::isfinite(x)) fail(field, "must be finite, got " + brief(v));
    return x;
  }

  double positive(const json& v, const std::string& field) const {
    if (!v.is_number()) fail(field, "must be a number, got " + brief(v));
    const double x = v.get<double>();
    if (!std::isfinite(x) || !(x > 0.0)) fail(field, "must be finite and > 0, got " + brief(v));
    return x;
  }

  double nonNegative(const json& v, const std::string& field) const {
    if (!v.is_number()) fail(field, "must be a number, got " + brief(v));
    const double x = v.get<double>();
    if (!std::isfinite(x) || !(x >= 0.0)) fail(field, "must be finite and >= 0, got " + brief(v));
    return x;
  }

  // x, failing with rangeError's message ("<field> = <x> is beyond <limit> <unit>") outside the range.
  double ranged(double x, double limit, const std::string& field, const char* unit) const {
    const std::string error = rangeError(x, limit, field, unit);
    if (!error.empty()) failPlain(error);
    return x;
  }

  // Each component within `limit`, and, when `norm_too`, the length as well ("|field|").
  const Eigen::Vector3d& rangedVec(const Eigen::Vector3d& x, double limit, const std::string& field, const char* unit,
                                   bool norm_too) const {
    for (int i = 0; i < 3; ++i) ranged(x[i], limit, field + "[" + std::to_string(i) + "]", unit);
    if (norm_too) ranged(x.norm(), limit, "|" + field + "|", unit);
    return x;
  }

  const json& array(const json& v, const std::string& field, size_t size, const char* of) const {
    if (!v.is_array() || v.size() != size) {
      fail(field, "must be an array of " + std::to_string(size) + " " + of + ", got " + brief(v));
    }
    return v;
  }

  Eigen::Vector3d vec3(const json& v, const std::string& field) const {
    array(v, field, 3, "numbers");
    Eigen::Vector3d out;
    for (int i = 0; i < 3; ++i) out[i] = number(v[i], field + "[" + std::to_string(i) + "]");
    return out;
  }

  // Points of a shape: each coordinate and each |point| within kMaxSize.
  std::vector<Eigen::Vector3d> points(const json& v, const std::string& field) const {
    if (!v.is_array() || v.empty()) fail(field, "must be a non-empty array of [x, y, z] points, got " + brief(v));
    std::vector<Eigen::Vector3d> out;
    out.reserve(v.size());
    for (size_t i = 0; i < v.size(); ++i) {
      const std::string f = field + "[" + std::to_string(i) + "]";
      out.push_back(rangedVec(vec3(v[i], f), kMaxSize, f, "m", true));
    }
    return out;
  }

  // A shape dimension: finite, > 0 (or >= 0) and within kMaxSize.
  double size(const json& v, const std::string& field, bool zero_ok = false) const {
    return ranged(zero_ok ? nonNegative(v, field) : positive(v, field), kMaxSize, field, "m");
  }

 private:
  std::string label_;
};

Shape readShape(const json& v, const Checker& c) {
  if (!v.is_object()) c.fail("shape", "must be an object, got " + brief(v));
  static const char* const kTypes = "sphere, box, cylinder, capsule, convex, mesh";
  const json& type = c.required(v, "type", "shape.type");
  if (!type.is_string()) c.fail("shape.type", std::string("must be a string (") + kTypes + "), got " + brief(type));
  const std::string t = type.get<std::string>();
  const std::string for_type = " for a " + t;
  if (t == "sphere") {
    c.onlyKeys(v, {"type", "radius"}, "shape", for_type);
    return makeSphere(c.size(c.required(v, "radius", "shape.radius"), "shape.radius"));
  }
  if (t == "box") {
    c.onlyKeys(v, {"type", "size"}, "shape", for_type);
    const json& size = c.required(v, "size", "shape.size");
    c.array(size, "shape.size", 3, "numbers");
    Eigen::Vector3d s;
    for (int i = 0; i < 3; ++i) s[i] = c.size(size[i], "shape.size[" + std::to_string(i) + "]");
    return makeBox(s);
  }
  if (t == "cylinder" || t == "capsule") {
    c.onlyKeys(v, {"type", "radius", "length"}, "shape", for_type);
    const double r = c.size(c.required(v, "radius", "shape.radius"), "shape.radius");
    const json& len = c.required(v, "length", "shape.length");
    if (t == "cylinder") return makeCylinder(r, c.size(len, "shape.length"));
    return makeCapsule(r, c.size(len, "shape.length", true));
  }
  if (t == "convex") {
    c.onlyKeys(v, {"type", "points"}, "shape", for_type);
    return makeConvex(c.points(c.required(v, "points", "shape.points"), "shape.points"));
  }
  if (t == "mesh") {
    c.onlyKeys(v, {"type", "vertices", "triangles"}, "shape", for_type);
    std::vector<Eigen::Vector3d> vertices = c.points(c.required(v, "vertices", "shape.vertices"), "shape.vertices");
    const json& tris = c.required(v, "triangles", "shape.triangles");
    if (!tris.is_array() || tris.empty()) {
      c.fail("shape.triangles", "must be a non-empty array of [i, j, k] vertex indices, got " + brief(tris));
    }
    const size_t n = vertices.size();
    if (n > static_cast<size_t>(std::numeric_limits<int>::max())) c.fail("shape.vertices", "has too many vertices");
    std::vector<std::array<int, 3>> triangles;
    triangles.reserve(tris.size());
    for (size_t i = 0; i < tris.size(); ++i) {
      const std::string field = "shape.triangles[" + std::to_string(i) + "]";
      c.array(tris[i], field, 3, "vertex indices");
      std::array<int, 3> tri{};
      for (int k = 0; k < 3; ++k) {
        const json& x = tris[i][k];
        const std::string f = field + "[" + std::to_string(k) + "]";
        const std::string range = "must be an integer vertex index in [0, " + std::to_string(n) + "), got ";
        if (!x.is_number_integer()) c.fail(f, range + brief(x));
        const bool in_range = x.is_number_unsigned() ? x.get<uint64_t>() < n
                                                     : x.get<int64_t>() >= 0 && static_cast<uint64_t>(x.get<int64_t>()) < n;
        if (!in_range) c.fail(f, range + brief(x));
        tri[k] = static_cast<int>(x.get<int64_t>());
      }
      triangles.push_back(tri);
    }
    return makeMesh(std::move(vertices), std::move(triangles));
  }
  c.fail("shape.type", std::string("must be one of ") + kTypes + ", got " + brief(type));
}

Eigen::Quaterniond readOrientation(const json& v, const Checker& c) {
  c.array(v, "orientation", 4, "numbers (a quaternion [x, y, z, w])");
  double q[4];
  for (int i = 0; i < 4; ++i) q[i] = c.number(v[i], "orientation[" + std::to_string(i) + "]");
  // Normalised scale-safely: divided by the largest |component| first, the norm lies in [1, 2],
  // so neither [0, 0, 1e200, 1e200] (whose norm overflows) nor [0, 0, 1e-200, 1e-200] (whose
  // squares underflow) is mistaken for zero. Only a real zero has no direction.
  double scale = 0.0;
  for (const double x : q) scale = std::max(scale, std::abs(x));
  if (!(scale > 0.0)) c.fail("orientation", "must be a non-zero quaternion [x, y, z, w], got " + brief(v));
  for (double& x : q) x /= scale;
  return Eigen::Quaterniond(q[3], q[0], q[1], q[2]).normalized();
}

// "path": [{"t": s, "position": [x, y, z], "orientation": [x, y, z, w] (optional)}, ...] and
// "after_path": "hold" | "continue" (default): the body follows the keyframes (timed_path.h)
// instead of a constant twist, which it must then not have.
void readPath(const json& v, const json& path, const Checker& c, SceneBody& body) {
  for (const char* key : {"position", "orientation", "linear_velocity", "angular_velocity"}) {
    if (v.count(key)) c.fail(key, "must not be given with a path (the path sets the motion)");
  }
  if (!path.is_array() || path.empty()) c.fail("path", "must be a non-empty array of keyframes, got " + brief(path));
  std::vector<Keyframe> keys;
  for (size_t i = 0; i < path.size(); ++i) {
    const std::string field = "path[" + std::to_string(i) + "]";
    const json& k = path[i];
    if (!k.is_object()) c.fail(field, "must be an object, got " + brief(k));
    c.onlyKeys(k, {"t", "position", "orientation"}, field);
    Keyframe f;
    f.time = c.number(c.required(k, "t", field + ".t"), field + ".t");
    const std::string range = rangeError(f.time, kMaxTime, field + ".t", "s");
    if (!range.empty()) c.failPlain(range);
    f.position = c.rangedVec(c.vec3(c.required(k, "position", field + ".position"), field + ".position"),
                             kMaxCoordinate, field + ".position", "m", false);
    if (const auto it = k.find("orientation"); it != k.end()) f.orientation = readOrientation(*it, c);
    keys.push_back(f);
  }
  AfterPath after = AfterPath::kContinue;
  if (const auto it = v.find("after_path"); it != v.end()) {
    if (*it == "hold") {
      after = AfterPath::kHold;
    } else if (*it != "continue") {
      c.fail("after_path", "must be \"hold\" or \"continue\", got " + brief(*it));
    }
  }
  try {
    body.path = std::make_shared<const TimedPath>(std::move(keys), after);
  } catch (const InvalidArgument& e) {
    c.failPlain(e.what());
  }
  body.motion = body.path->motion(0);
}

SceneBody readBody(const json& v, size_t index, std::unordered_map<std::string, size_t>& seen) {
  if (!v.is_object()) Checker(bodyLabel(index, nullptr)).failPlain("must be a JSON object, got " + brief(v));
  const auto id_it = v.find("id");
  if (id_it == v.end()) Checker(bodyLabel(index, nullptr)).fail("id", "is missing");
  if (!id_it->is_string() || id_it->get_ref<const std::string&>().empty()) {
    Checker(bodyLabel(index, nullptr)).fail("id", "must be a non-empty string, got " + brief(*id_it));
  }
  SceneBody body;
  body.id = id_it->get<std::string>();
  const Checker c(bodyLabel(index, &body.id));
  const auto dup = seen.find(body.id);
  if (dup != seen.end()) {
    c.fail("id", "is already used by the body at index " + std::to_string(dup->second));
  }
  c.onlyKeys(v, {"id", "shape", "position", "orientation", "linear_velocity", "angular_velocity", "path", "after_path"},
             "");
  try {
    body.shape = readShape(c.required(v, "shape", "shape"), c);
  } catch (const InvalidArgument& e) {
    // Our checks name the field; this only catches a make* check they do not duplicate.
    const std::string msg = e.what();
    if (msg.rfind("body ", 0) == 0) throw;
    c.fail("shape:", msg);
  }
  if (const auto path = v.find("path"); path != v.end()) {
    readPath(v, *path, c, body);
    seen.emplace(body.id, index);
    return body;
  }
  if (v.count("after_path")) c.fail("after_path", "needs a path");
  const Eigen::Vector3d position =
      c.rangedVec(c.vec3(c.required(v, "position", "position"), "position"), kMaxCoordinate, "position", "m", false);
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d linear = Eigen::Vector3d::Zero(), angular = Eigen::Vector3d::Zero();
  if (const auto it = v.find("orientation"); it != v.end()) orientation = readOrientation(*it, c);
  if (const auto it = v.find("linear_velocity"); it != v.end()) {
    linear = c.rangedVec(c.vec3(*it, "linear_velocity"), kMaxLinearSpeed, "linear_velocity", "m/s", true);
  }
  if (const auto it = v.find("angular_velocity"); it != v.end()) {
    angular = c.rangedVec(c.vec3(*it, "angular_velocity"), kMaxAngularSpeed, "angular_velocity", "rad/s", true);
  }
  try {
    body.motion = makeMotion(position, orientation, linear, angular, 0.0);
  } catch (const InvalidArgument& e) {
    c.failPlain(e.what());
  }
  seen.emplace(body.id, index);
  return body;
}

Scene parseSceneUnbounded(const std::string& json_text) {
  const json root = parseJson(json_text);
  if (!root.is_object()) Checker("scene").failPlain("must be a JSON object, got " + brief(root));
  Checker("scene").onlyKeys(root, {"horizon", "bodies"}, "");
  const Checker c("");
  Scene scene;
  scene.horizon = c.ranged(c.nonNegative(c.required(root, "horizon", "horizon"), "horizon"), kMaxTime, "horizon", "s");
  const json& bodies = c.required(root, "bodies", "bodies");
  if (!bodies.is_array()) c.fail("bodies", "must be an array of body objects, got " + brief(bodies));
  scene.bodies.reserve(bodies.size());
  std::unordered_map<std::string, size_t> seen;
  for (size_t i = 0; i < bodies.size(); ++i) scene.bodies.push_back(readBody(bodies[i], i, seen));
  return scene;
}

// At most kMaxSceneBytes + 1 bytes of `in`: one more than the limit shows that it is exceeded,
// whatever the stream is (a regular file, a pipe, /dev/zero).
std::string readLimited(std::istream& in, const std::string& name) {
  std::string text;
  std::vector<char> buf(size_t{1} << 16);
  errno = 0;
  try {
    while (text.size() <= kMaxSceneBytes) {
      in.read(buf.data(), static_cast<std::streamsize>(std::min(buf.size(), kMaxSceneBytes + 1 - text.size())));
      text.append(buf.data(), static_cast<size_t>(in.gcount()));
      if (!in) break;
    }
  } catch (const std::ios_base::failure&) {  // libstdc++ can throw here for a directory
    in.setstate(std::ios::badbit);
  }
  if (in.bad()) {
    throw InvalidArgument(oneLine("cannot read " + name + (errno ? std::string(": ") + std::strerror(errno) : "")));
  }
  if (text.size() > kMaxSceneBytes) {
    throw InvalidArgument(oneLine(name + " is larger than " + std::to_string(kMaxSceneBytes >> 20) + " MiB (" +
                                  std::to_string(kMaxSceneBytes) + " bytes), the limit of a scene"));
  }
  return text;
}

}  // namespace

std::string messageQuote(const std::string& s) {
  // Only a prefix is escaped: a 1 MB id is never serialized whole. (A multi-byte character cut
  // at the end becomes U+FFFD.)
  const bool long_input = s.size() > kMaxQuotedChars;
  const std::string q = json(long_input ? s.substr(0, kMaxQuotedChars) : s)
                            .dump(-1, ' ', true, json::error_handler_t::replace);
  std::string inner = q.substr(1, q.size() - 2);
  // Cut at an escape boundary once it exceeds kMaxQuotedChars characters.
  size_t end = 0;
  while (end < inner.size()) {
    const size_t len = inner[end] != '\\' ? 1 : inner[end + 1] == 'u' ? 6 : 2;
    if (end + len > kMaxQuotedChars) break;
    end += len;
  }
  const bool cut = long_input || end < inner.size();
  inner.resize(end);
  return "\"" + inner + (cut ? "...\"" : "\"");
}

std::string boundedMessage(const std::string& s, size_t max_bytes) {
  std::string out = s.size() > max_bytes ? s.substr(0, max_bytes >= 3 ? max_bytes - 3 : 0) + "..." : s;
  if (out.size() > max_bytes) out.resize(max_bytes);
  for (char& c : out) {
    const auto u = static_cast<unsigned char>(c);
    if (u < 0x20 || u == 0x7f) c = ' ';
    if (u >= 0x80) c = '?';
  }
  return out;
}

Scene parseScene(const std::string& json_text) {
  try {
    return parseSceneUnbounded(json_text);
  } catch (const InvalidArgument& e) {
    // Every message is one line of at most kMaxMessageBytes, also one from a make* check.
    throw InvalidArgument(boundedMessage(e.what()));
  }
}

Scene readScene(std::istream& in, const std::string& name) { return parseScene(readLimited(in, name)); }

Scene readSceneFile(const std::string& path) {
  const std::string name = "scene file " + quoted(path);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InvalidArgument(oneLine("cannot open " + name + ": " + std::strerror(errno)));
  return readScene(in, name);
}

void addToWorld(const Scene& scene, World& world) {
  size_t added = 0;
  try {
    for (const SceneBody& b : scene.bodies) {
      world.add(b.id, b.shape, b.motion);
      ++added;
      if (b.path) world.setPath(b.id, *b.path);
    }
  } catch (...) {
    while (added > 0) world.remove(scene.bodies[--added].id);
    throw;
  }
}

std::string impactToJson(const Contact& w) {
  auto vec = [](const Eigen::Vector3d& v) {
    // + 0.0 turns -0 into +0: the same point, one spelling.
    return nlohmann::ordered_json::array({v.x() + 0.0, v.y() + 0.0, v.z() + 0.0});
  };
  nlohmann::ordered_json j;
  j["a"] = w.a;
  j["b"] = w.b;
  j["time"] = w.impact.time + 0.0;
  j["point"] = vec(w.impact.point);
  j["normal"] = vec(w.impact.normal);
  return j.dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
}

std::string impactsToJsonLines(const std::vector<Contact>& impacts) {
  std::string out;
  for (const Contact& w : impacts) {
    out += impactToJson(w);
    out += '\n';
  }
  return out;
}

std::string undecidedToJson(const Contact& w) {
  nlohmann::ordered_json j;
  j["a"] = w.a;
  j["b"] = w.b;
  j["undecided_after"] = w.impact.time + 0.0;
  return j.dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
}

std::string predictionToJsonLines(const std::vector<Contact>& impacts, const std::vector<Contact>& undecided) {
  std::vector<std::pair<const Contact*, bool>> all;  // (pair, undecided)
  all.reserve(impacts.size() + undecided.size());
  for (const Contact& w : impacts) all.emplace_back(&w, false);
  for (const Contact& w : undecided) all.emplace_back(&w, true);
  std::stable_sort(all.begin(), all.end(), [](const auto& x, const auto& y) {
    const Contact& a = *x.first;
    const Contact& b = *y.first;
    if (a.impact.time != b.impact.time) return a.impact.time < b.impact.time;
    if (a.a_key != b.a_key) return a.a_key < b.a_key;
    return a.b_key < b.b_key;
  });
  std::string out;
  for (const auto& [w, is_undecided] : all) {
    out += is_undecided ? undecidedToJson(*w) : impactToJson(*w);
    out += '\n';
  }
  return out;
}

}  // namespace vadop
