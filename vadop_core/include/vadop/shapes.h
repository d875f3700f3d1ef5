// Collision shapes in their body frame, centred on the body origin (URDF conventions).
// A Shape answers support queries (the farthest point along a direction), which is all the
// broad phase needs; the narrow phase adds its own geometry on top. Shapes are immutable
// values; validation happens once, at construction through the make* functions.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <array>
#include <string>
#include <vector>

namespace vadop {

enum class ShapeType { kSphere, kBox, kCapsule, kCylinder, kConvex, kMesh };

const char* toString(ShapeType type);

// Plain data. Use the make* functions below: they validate and fill the derived fields.
struct Shape {
  ShapeType type = ShapeType::kSphere;
  double radius = 0.0;                           // sphere, capsule, cylinder
  double half_length = 0.0;                      // capsule segment / cylinder, along body z
  Eigen::Vector3d half_extents = Eigen::Vector3d::Zero();  // box
  std::vector<Eigen::Vector3d> points;           // convex: the point set; mesh: the vertices
  std::vector<std::array<int, 3>> triangles;     // mesh only
  // Padding: the shape is the Minkowski sum of the above with a ball of this radius.
  double margin = 0.0;
  // Derived: the largest distance from the body origin to any point of the shape
  // (margin included): the lever arm that bounds how far rotation moves a point.
  double bounding_radius = 0.0;
};

// Each throws vadop::InvalidArgument naming the field when a size is not finite and > 0,
// a point is not finite, a triangle index is out of range, or a point set is empty.
Shape makeSphere(double radius);
Shape makeBox(const Eigen::Vector3d& size);  // full edge lengths, as URDF <box size>
Shape makeCapsule(double radius, double length);   // length = segment length, along z
Shape makeCylinder(double radius, double length);  // length = full height, along z
Shape makeConvex(std::vector<Eigen::Vector3d> points);
Shape makeMesh(std::vector<Eigen::Vector3d> vertices, std::vector<std::array<int, 3>> triangles);

// Obstacles a sensor sees, as one shape (a laser scan, a point cloud, an occupancy grid's
// occupied cells), in its body frame: a ball of `radius` about each point (a mesh whose
// triangles are the points, grown by the radius: the mesh's bounding-volume tree and narrow
// phase serve it), or a box of `size` (full edges) about each centre (a mesh of the boxes'
// faces: a body wholly inside one box does not touch it). Throws vadop::InvalidArgument for no
// point, a point that is not finite, or a radius / size that is not finite and > 0.
// Everywhere a mesh goes (distance, timeOfImpact under every motion, World's queries), a point
// triangle is its point: nothing needs its normal or area. As for any mesh, a point set meets
// the primitives (solid) and a mesh body as a surface: a point wholly inside a mesh body is not
// touched. Costs (one core, RelWithDebInfo): building the tree (PreparedShape, World::add) about
// 0.25 ms for 1,081 points, 2 ms for 5,000, 20 to 40 ms for 30,000 (filter clouds first); each
// World::predict also reads every point a few dozen times (the broad phase's support queries of
// the shape). JSON scenes (scene_io.h) carry no padding: a point set is not expressible there.
Shape makePointSet(std::vector<Eigen::Vector3d> points, double radius);
Shape makeBoxSet(const std::vector<Eigen::Vector3d>& centres, const Eigen::Vector3d& size);

// Returns the shape grown by `padding` metres in every direction: the exact Minkowski sum
// with a ball (it adds to `margin`). Throws when padding is negative or not finite.
Shape inflate(const Shape& shape, double padding);

// The shape placed at `pose` in a frame of its own (its points x become pose * x), as a shape
// centred on that frame's origin: for a body whose motion is given for a frame other than the
// shape's (a link rigid with a turning robot turns about the robot's origin, not its own).
// Exact for every type (a sphere becomes a point with rounding, a capsule two points, a box
// eight) but the cylinder, which becomes the prism over a regular 24-gon circumscribing it
// (a conservative bound: at most 0.86% of the radius larger). The identity returns the shape
// itself. Throws vadop::InvalidArgument when the pose is not finite or not a rigid transform.
Shape transformShape(const Shape& shape, const Eigen::Isometry3d& pose);

// Support value h(d) = max over shape points x of d.x, for a direction d in the body frame
// (d need not be unit; h is positively homogeneous). Exact for every shape type; a mesh
// answers for its convex hull, which is what a bounding volume needs.
double support(const Shape& shape, const Eigen::Vector3d& d);

// The farthest point of the shape along d (body frame); d must be non-zero. Ties are
// broken deterministically.
Eigen::Vector3d supportPoint(const Shape& shape, const Eigen::Vector3d& d);

// Throws vadop::InvalidArgument, prefixed with `what`, when the shape's fields are not a
// valid shape (for Shape values built by hand rather than by the make* functions).
void validateShape(const Shape& shape, const std::string& what);

}  // namespace vadop
