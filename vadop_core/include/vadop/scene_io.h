// Scenes as JSON text (the input of vadop_predict) and impacts as JSON lines (its output).
//
//   {"horizon": 2.0,
//    "bodies": [ {"id": "a", "shape": {"type": "sphere", "radius": 0.5},
//                 "position": [0,0,0], "orientation": [0,0,0,1],
//                 "linear_velocity": [1,0,0], "angular_velocity": [0,0,0]}, ...]}
//
// horizon (s): required, finite, >= 0. bodies: required array (may be empty) of objects with
//  - id: required non-empty string, unique in the scene;
//  - shape: required object, URDF conventions, centred on the body origin:
//      {"type": "sphere",   "radius": r}
//      {"type": "box",      "size": [x, y, z]}            full edge lengths
//      {"type": "cylinder", "radius": r, "length": l}      along body z, l = full height
//      {"type": "capsule",  "radius": r, "length": l}      along body z, l = segment length (>= 0)
//      {"type": "convex",   "points": [[x,y,z], ...]}      the convex hull of the points
//      {"type": "mesh",     "vertices": [[x,y,z], ...], "triangles": [[i,j,k], ...]}
//    sizes finite and > 0, points finite, triangle indices integers in [0, #vertices);
//  - position: required [x, y, z] (m, fixed frame);
//  - orientation: [x, y, z, w] quaternion, normalised on reading, not zero; default identity;
//  - linear_velocity [m/s] and angular_velocity [rad/s, fixed frame, about the body origin]:
//    [x, y, z], default zero. The pose holds at t = 0; the motion is rigid with constant
//    velocities (motion.h).
//  - or instead of those four, path: [{"t": s, "position": [x, y, z], "orientation": [x, y, z,
//    w] (optional)}, ...] with t increasing, and after_path: "hold" | "continue" (default):
//    the body follows the timed poses (timed_path.h).
// Range (error.h): |position[i]| <= kMaxCoordinate; every shape dimension (radius, length,
// size[i], point coordinates and |point|) <= kMaxSize; |velocity[i]| and |velocity| <=
// kMaxLinearSpeed (m/s) / kMaxAngularSpeed (rad/s); horizon <= kMaxTime. Each is checked where
// it is read, so the message names body, index and field:
//   body "a" (index 0): position[0] = 1000000000000 is beyond 10000000 m
// Input limits (below): at most kMaxSceneBytes of text and kMaxSceneDepth levels of nesting.
// Strict: unknown keys (a typo such as "linear_velocty" would otherwise silently mean a zero
// velocity), duplicate keys, wrong types or array sizes, numbers that overflow a double (1e999)
// and trailing text (also after a NUL byte) are all errors. Every error throws
// vadop::InvalidArgument with a one-line message of at most kMaxMessageBytes naming the body (by
// id and index when the id is known, else by index) and the field:
//   body "b" (index 1): shape.radius must be finite and > 0, got -1
#pragma once

#include "vadop/motion.h"
#include "vadop/shapes.h"
#include "vadop/timed_path.h"
#include "vadop/world.h"

#include <cstddef>
#include <iosfwd>
#include <memory>
#include <string>
#include <vector>

namespace vadop {

// Scene text is read up to this size (64 MiB); readScene/readSceneFile read at most one byte
// more, so a larger input (also a pipe or a device such as /dev/zero) is an error, found
// without reading it all.
constexpr size_t kMaxSceneBytes = size_t{64} << 20;
// Arrays and objects nest at most this deep (the scene object is level 1; a scene needs 6:
// scene, bodies, body, shape, points, point). Deeper input is rejected by the parser as it
// opens the 65th level, before anything recurses over it.
constexpr int kMaxSceneDepth = 64;
// Every message of parseScene, readScene and readSceneFile is one line of at most this many
// bytes: ids, keys and values are quoted shortened (messageQuote), paths and values elided.
constexpr size_t kMaxMessageBytes = 300;
// Characters of a quoted string's content that messages show (messageQuote).
constexpr size_t kMaxQuotedChars = 40;

struct SceneBody {
  std::string id;
  Shape shape;
  Motion motion;  // t_ref = 0; with a path, its first piece
  std::shared_ptr<const TimedPath> path;  // "path" given (addToWorld: World::setPath), else null
};

struct Scene {
  double horizon = 0.0;
  std::vector<SceneBody> bodies;  // in input order
};

// Parses a scene from JSON text, all of it (a NUL byte does not end it). Throws
// vadop::InvalidArgument (see above).
Scene parseScene(const std::string& json_text);
// Reads (at most kMaxSceneBytes) and parses a file. Throws vadop::InvalidArgument, also when the
// file cannot be read or is larger than kMaxSceneBytes.
Scene readSceneFile(const std::string& path);
// The same for a stream, such as std::cin; `name` names it in messages ("standard input").
Scene readScene(std::istream& in, const std::string& name);

// `s` as a JSON string literal for a message: escaped, ASCII only, its content shortened to at
// most kMaxQuotedChars characters with "..." before the closing quote. The one helper every
// message that quotes input (ids, keys, string values, file names) uses.
std::string messageQuote(const std::string& s);
// A message made one printable line (control characters become spaces, bytes >= 0x80 '?') of
// at most max_bytes bytes (cut with "..." at the end).
std::string boundedMessage(const std::string& s, size_t max_bytes = kMaxMessageBytes);

// Adds the scene's bodies to `world` in input order (so World keys follow input order).
// All or nothing: on an error the bodies added so far are removed again and it rethrows.
void addToWorld(const Scene& scene, World& world);

// One impact as a single-line JSON object, keys in this order:
//   {"a":"<id>","b":"<id>","time":t,"point":[x,y,z],"normal":[x,y,z]}
// Numbers are printed in the shortest form that reads back to the same double; -0 prints as 0.
std::string impactToJson(const Contact& impact);
// impactToJson of each, one a line, each line ending in '\n'.
std::string impactsToJsonLines(const std::vector<Contact>& impacts);

// A pair the narrow phase could not decide within its budget (World::lastUndecided: clear up to
// impact.time, unknown after; not a contact) as a single-line JSON object:
//   {"a":"<id>","b":"<id>","undecided_after":t}
std::string undecidedToJson(const Contact& undecided);
// The output of vadop_predict: impactToJson of each contact and undecidedToJson of each
// undecided pair, one a line, merged and sorted by time, then a_key, then b_key (input order).
std::string predictionToJsonLines(const std::vector<Contact>& impacts,
                                  const std::vector<Contact>& undecided);

}  // namespace vadop
