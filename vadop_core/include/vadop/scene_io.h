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
// Strict: unknown keys (a typo such as "linear_velocty" would otherwise silently mean a zero
// velocity), duplicate keys, wrong types or array sizes, numbers that overflow a double (1e999)
// and trailing text are all errors. Every error throws vadop::InvalidArgument with a one-line
// message naming the body (by id and index when the id is known, else by index) and the field:
//   body "b" (index 1): shape.radius must be finite and > 0, got -1
#pragma once

#include "vadop/motion.h"
#include "vadop/shapes.h"
#include "vadop/world.h"

#include <string>
#include <vector>

namespace vadop {

struct SceneBody {
  std::string id;
  Shape shape;
  Motion motion;  // t_ref = 0
};

struct Scene {
  double horizon = 0.0;
  std::vector<SceneBody> bodies;  // in input order
};

// Parses a scene from JSON text. Throws vadop::InvalidArgument (see above).
Scene parseScene(const std::string& json_text);
// Reads and parses a file. Throws vadop::InvalidArgument, also when the file cannot be read.
Scene readSceneFile(const std::string& path);

// Adds the scene's bodies to `world` in input order (so World keys follow input order).
// All or nothing: on an error the bodies added so far are removed again and it rethrows.
void addToWorld(const Scene& scene, World& world);

// One impact as a single-line JSON object, keys in this order:
//   {"a":"<id>","b":"<id>","time":t,"point":[x,y,z],"normal":[x,y,z]}
// Numbers are printed in the shortest form that reads back to the same double; -0 prints as 0.
std::string impactToJson(const WorldImpact& impact);
// impactToJson of each, one a line, each line ending in '\n'.
std::string impactsToJsonLines(const std::vector<WorldImpact>& impacts);

}  // namespace vadop
