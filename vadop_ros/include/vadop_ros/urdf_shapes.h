// URDF -> collision shapes: every <collision> element of every link, with its origin and,
// for meshes, its scale. box, cylinder and sphere map to the library's primitives; a mesh
// (package:// or file:// URI, read from its file and loaded with assimp) to a triangle mesh.
//
// Mesh files are bounded: a URI is resolved to a path first (package:// with
// ros::package::getPath, as resource_retriever does), and anything but a regular file of at most
// kMaxMeshBytes is refused before a byte is read (file:///dev/zero, a FIFO, a 2 GB file), with an
// error naming the URI and the limit. Other schemes (http://, ...) are refused: a remote
// resource could not be bounded before it is read.
//
// Link poses: urdfToShapes also computes each link's pose in the root link's frame with every
// joint at its zero position (a fixed joint's origin), which is the pose of a link that moves
// rigidly with the body. Robots whose links move get their link poses from tf instead (see
// body_registry.h); the zero-position poses are then unused.
//
// Errors: a URDF that does not parse throws UrdfError. A collision element that cannot be
// converted (unloadable mesh, unsupported or invalid geometry) does not: it is left out and
// described in UrdfShapes::errors, naming the link, so that the rest of the robot is monitored.
#pragma once

#include <vadop/shapes.h>

#include <Eigen/Geometry>

#include <array>
#include <functional>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace vadop_ros {

class UrdfError : public std::runtime_error {
 public:
  explicit UrdfError(const std::string& what) : std::runtime_error(what) {}
};

// One collision element of one link.
struct LinkGeometry {
  std::string link;                   // URDF link name
  int index = 0;                      // index among the link's collision elements
  vadop::Shape shape;                 // unpadded, in the collision element's frame
  Eigen::Isometry3d origin = Eigen::Isometry3d::Identity();  // collision origin in the link frame
  std::string mesh_uri;               // meshes only (markers show the mesh itself)
  Eigen::Vector3d mesh_scale = Eigen::Vector3d::Ones();
};

struct UrdfShapes {
  std::string robot_name;
  std::string root_link;
  std::vector<LinkGeometry> geometries;
  // Pose of every link in the root link's frame, every joint at zero.
  std::map<std::string, Eigen::Isometry3d> link_in_root;
  // Links joined by a joint (parent, child): never reported as self-collisions.
  std::vector<std::pair<std::string, std::string>> adjacent;
  // Links whose pose relative to the root depends on a movable joint.
  std::vector<std::string> movable_links;
  // One message per collision element left out, naming the link.
  std::vector<std::string> errors;
};

// A loaded mesh: vertices (scaled) and triangles.
struct MeshData {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<std::array<int, 3>> triangles;
};

// Loads a mesh resource; throws std::runtime_error with a readable message when it cannot.
using MeshLoader = std::function<MeshData(const std::string& uri, const Eigen::Vector3d& scale)>;

// Largest mesh file read (bytes): 64 MiB, some 1.3 million triangles as binary STL, far more
// than a collision mesh needs (the narrow phase works on the mesh's points).
constexpr unsigned long long kMaxMeshBytes = 64ull << 20;

// The file a package:// or file:// mesh URI names. Throws std::runtime_error naming the URI for
// another scheme, a malformed URI or an unknown package.
std::string meshPath(const std::string& uri);

// The bytes of the mesh file `uri` names (meshPath). Throws std::runtime_error naming the URI
// when it is not a regular file, is larger than kMaxMeshBytes (naming the limit) or cannot be read.
std::vector<char> readMeshResource(const std::string& uri);

// readMeshResource + assimp, with a cache by (uri, scale) shared by the copies of a robot.
MeshLoader makeDefaultMeshLoader();

// Parses the URDF text. Throws UrdfError when it does not parse (the message says why, when
// urdfdom tells).
UrdfShapes urdfToShapes(const std::string& urdf_xml, const MeshLoader& load_mesh);

}  // namespace vadop_ros
