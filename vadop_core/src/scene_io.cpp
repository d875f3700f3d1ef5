#include "vadop/scene_io.h"

#include "vadop/error.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
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

// A JSON value as compact one-line text; ASCII only, so messages stay printable.
std::string dumpOneLine(const json& v) {
  return v.dump(-1, ' ', true, json::error_handler_t::replace);
}

std::string quoted(const std::string& s) { return dumpOneLine(json(s)); }

// "got ..." text: the value itself, shortened.
std::string brief(const json& v) {
  std::string s = dumpOneLine(v);
  if (s.size() > 60) s = s.substr(0, 57) + "...";
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

// Replaces control characters (a parser message can quote raw input) so a message is one line.
std::string oneLine(std::string s) {
  for (char& c : s) {
    const auto u = static_cast<unsigned char>(c);
    if (u < 0x20 || u == 0x7f) c = ' ';
  }
  return s;
}

// ------------------------------------------------------------------ parsing with a location

// Tracks where the parser is (the path of keys and array indices), so that errors raised by
// the parser itself (syntax, number overflow) and duplicate keys can name body and field, and
// records the body ids seen so far for those messages.
// A key as a path component: as is when it is a plain name, else JSON-quoted (escaped, and
// shortened when long), so that the path stays on one line and readable.
std::string pathKey(const std::string& key) {
  const bool plain = !key.empty() && key.size() <= 40 && std::all_of(key.begin(), key.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
  });
  if (plain) return key;
  std::string q = quoted(key);
  if (q.size() > 60) q = q.substr(0, 56) + "...\"";
  return q;
}

class Locator {
 public:
  struct DuplicateKey {
    std::string message;
  };

  bool operator()(int /*depth*/, json::parse_event_t event, json& parsed) {
    switch (event) {
      case json::parse_event_t::object_start: frames_.push_back(Frame{false, 0, {}, {}}); break;
      case json::parse_event_t::array_start: frames_.push_back(Frame{true, 0, {}, {}}); break;
      case json::parse_event_t::key: {
        Frame& f = frames_.back();
        std::string k = parsed.get<std::string>();
        if (!f.keys.insert(k).second) {
          f.key = std::move(k);
          throw DuplicateKey{where() + " is given twice (duplicate key)"};
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
    std::string label, field;
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
        field += "[" + std::to_string(f.index) + "]";
      } else if (!f.key.empty() || !f.keys.empty()) {
        field += (field.empty() ? "" : ".") + pathKey(f.key);
      }
    }
    if (label.empty()) return field;
    return field.empty() ? label : label + ": " + field;
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
  try {
    return json::parse(text, std::ref(locator));
  } catch (const Locator::DuplicateKey& e) {
    throw InvalidArgument(oneLine(e.message));
  } catch (const json::out_of_range& e) {
    // 406: a number that overflows a double (JSON itself has no NaN or Inf).
    std::string token = e.what();
    const size_t open = token.find('\''), close = token.rfind('\'');
    token = open != std::string::npos && close > open ? token.substr(open + 1, close - open - 1) : "a number";
    const std::string at = locator.where();
    throw InvalidArgument(oneLine((at.empty() ? "scene" : at) + " must be finite, got " + token +
                                  " (out of the range of a double)"));
  } catch (const json::exception& e) {
    std::string msg = e.what();
    const std::string prefix = "parse error at ";
    const size_t p = msg.find(prefix);
    msg = p != std::string::npos ? msg.substr(p + prefix.size()) : msg.substr(msg.find(']') + 1);
    const std::string at = locator.where();
    throw InvalidArgument(oneLine((at.empty() ? std::string() : at + ": ") + "malformed JSON at " + msg));
  }
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

  std::vector<Eigen::Vector3d> points(const json& v, const std::string& field) const {
    if (!v.is_array() || v.empty()) fail(field, "must be a non-empty array of [x, y, z] points, got " + brief(v));
    std::vector<Eigen::Vector3d> out;
    out.reserve(v.size());
    for (size_t i = 0; i < v.size(); ++i) out.push_back(vec3(v[i], field + "[" + std::to_string(i) + "]"));
    return out;
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
    return makeSphere(c.positive(c.required(v, "radius", "shape.radius"), "shape.radius"));
  }
  if (t == "box") {
    c.onlyKeys(v, {"type", "size"}, "shape", for_type);
    const json& size = c.required(v, "size", "shape.size");
    c.array(size, "shape.size", 3, "numbers");
    Eigen::Vector3d s;
    for (int i = 0; i < 3; ++i) s[i] = c.positive(size[i], "shape.size[" + std::to_string(i) + "]");
    return makeBox(s);
  }
  if (t == "cylinder" || t == "capsule") {
    c.onlyKeys(v, {"type", "radius", "length"}, "shape", for_type);
    const double r = c.positive(c.required(v, "radius", "shape.radius"), "shape.radius");
    const json& len = c.required(v, "length", "shape.length");
    if (t == "cylinder") return makeCylinder(r, c.positive(len, "shape.length"));
    return makeCapsule(r, c.nonNegative(len, "shape.length"));
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
  // The norm without overflow or underflow: scale by the largest component first.
  double scale = 0.0;
  for (const double x : q) scale = std::max(scale, std::abs(x));
  double norm = 0.0;
  if (scale > 0.0) {
    for (double& x : q) x /= scale;
    norm = scale * std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  }
  if (!(norm >= 1e-9)) {
    c.fail("orientation", "must be a non-zero quaternion [x, y, z, w] (norm >= 1e-9), got " + brief(v));
  }
  return Eigen::Quaterniond(q[3], q[0], q[1], q[2]).normalized();
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
  c.onlyKeys(v, {"id", "shape", "position", "orientation", "linear_velocity", "angular_velocity"}, "");
  try {
    body.shape = readShape(c.required(v, "shape", "shape"), c);
  } catch (const InvalidArgument& e) {
    // Our checks name the field; this only catches a make* check they do not duplicate.
    const std::string msg = e.what();
    if (msg.rfind("body ", 0) == 0) throw;
    c.fail("shape:", msg);
  }
  const Eigen::Vector3d position = c.vec3(c.required(v, "position", "position"), "position");
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d linear = Eigen::Vector3d::Zero(), angular = Eigen::Vector3d::Zero();
  if (const auto it = v.find("orientation"); it != v.end()) orientation = readOrientation(*it, c);
  if (const auto it = v.find("linear_velocity"); it != v.end()) linear = c.vec3(*it, "linear_velocity");
  if (const auto it = v.find("angular_velocity"); it != v.end()) angular = c.vec3(*it, "angular_velocity");
  try {
    body.motion = makeMotion(position, orientation, linear, angular, 0.0);
  } catch (const InvalidArgument& e) {
    c.failPlain(e.what());
  }
  seen.emplace(body.id, index);
  return body;
}

}  // namespace

Scene parseScene(const std::string& json_text) {
  const json root = parseJson(json_text);
  if (!root.is_object()) Checker("scene").failPlain("must be a JSON object, got " + brief(root));
  Checker("scene").onlyKeys(root, {"horizon", "bodies"}, "");
  const Checker c("");
  Scene scene;
  scene.horizon = c.nonNegative(c.required(root, "horizon", "horizon"), "horizon");
  const json& bodies = c.required(root, "bodies", "bodies");
  if (!bodies.is_array()) c.fail("bodies", "must be an array of body objects, got " + brief(bodies));
  scene.bodies.reserve(bodies.size());
  std::unordered_map<std::string, size_t> seen;
  for (size_t i = 0; i < bodies.size(); ++i) scene.bodies.push_back(readBody(bodies[i], i, seen));
  return scene;
}

Scene readSceneFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InvalidArgument("cannot open scene file " + quoted(path) + ": " + std::strerror(errno));
  std::string text;
  errno = 0;
  try {
    text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  } catch (const std::ios_base::failure&) {  // libstdc++ throws here for a directory
    in.setstate(std::ios::badbit);
  }
  if (in.bad()) {
    throw InvalidArgument("cannot read scene file " + quoted(path) + (errno ? std::string(": ") + std::strerror(errno) : ""));
  }
  return parseScene(text);
}

void addToWorld(const Scene& scene, World& world) {
  size_t added = 0;
  try {
    for (const SceneBody& b : scene.bodies) {
      world.add(b.id, b.shape, b.motion);
      ++added;
    }
  } catch (...) {
    while (added > 0) world.remove(scene.bodies[--added].id);
    throw;
  }
}

std::string impactToJson(const WorldImpact& w) {
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

std::string impactsToJsonLines(const std::vector<WorldImpact>& impacts) {
  std::string out;
  for (const WorldImpact& w : impacts) {
    out += impactToJson(w);
    out += '\n';
  }
  return out;
}

}  // namespace vadop
