#include "vadop/shapes.h"

#include "vadop/error.h"

#include <cmath>
#include <sstream>

namespace vadop {
namespace {

void requirePositive(double value, const char* field) {
  if (!std::isfinite(value) || value <= 0.0) {
    throw InvalidArgument(std::string(field) + " must be finite and > 0, got " + formatNumber(value));
  }
}

void requireFinitePoints(const std::vector<Eigen::Vector3d>& points, const char* field) {
  if (points.empty()) throw InvalidArgument(std::string(field) + " must not be empty");
  for (size_t i = 0; i < points.size(); ++i) {
    if (!points[i].allFinite()) {
      throw InvalidArgument(std::string(field) + "[" + std::to_string(i) + "] is not finite");
    }
  }
}

double maxNorm(const std::vector<Eigen::Vector3d>& points) {
  double r = 0.0;
  for (const auto& p : points) r = std::max(r, p.norm());
  return r;
}

void requireSize(double value, const std::string& field) {
  const std::string error = rangeError(value, kMaxSize, field, "m");
  if (!error.empty()) throw InvalidArgument(error);
}

// The range of error.h (kMaxSize) for every dimension, point and the margin of a shape whose
// fields are otherwise valid (finite, positive). One check for validateShape and the make*
// functions. Edge lengths and lengths are the full ones, as the make* functions take them.
void requireShapeRange(const Shape& s) {
  switch (s.type) {
    case ShapeType::kSphere: requireSize(s.radius, "sphere radius"); break;
    case ShapeType::kBox:
      for (int k = 0; k < 3; ++k) requireSize(2.0 * s.half_extents[k], "box size[" + std::to_string(k) + "]");
      break;
    case ShapeType::kCapsule:
    case ShapeType::kCylinder: {
      const std::string name = s.type == ShapeType::kCapsule ? "capsule" : "cylinder";
      requireSize(s.radius, name + " radius");
      requireSize(2.0 * s.half_length, name + " length");
      break;
    }
    case ShapeType::kConvex:
    case ShapeType::kMesh: {
      const char* name = s.type == ShapeType::kConvex ? "|convex points[" : "|mesh vertices[";
      for (size_t i = 0; i < s.points.size(); ++i) {
        const double sq = s.points[i].squaredNorm();
        if (sq <= kMaxSize * kMaxSize) continue;  // the common case, without a sqrt
        requireSize(std::isfinite(sq) ? std::sqrt(sq) : s.points[i].stableNorm(),
                    name + std::to_string(i) + "]|");
      }
      break;
    }
  }
  requireSize(s.margin, "margin");
}

void finish(Shape& s) {
  switch (s.type) {
    case ShapeType::kSphere: s.bounding_radius = s.radius; break;
    case ShapeType::kBox: s.bounding_radius = s.half_extents.norm(); break;
    case ShapeType::kCapsule: s.bounding_radius = s.half_length + s.radius; break;
    case ShapeType::kCylinder: s.bounding_radius = std::hypot(s.half_length, s.radius); break;
    case ShapeType::kConvex:
    case ShapeType::kMesh: s.bounding_radius = maxNorm(s.points); break;
  }
  s.bounding_radius += s.margin;
}

}  // namespace

const char* toString(ShapeType type) {
  switch (type) {
    case ShapeType::kSphere: return "sphere";
    case ShapeType::kBox: return "box";
    case ShapeType::kCapsule: return "capsule";
    case ShapeType::kCylinder: return "cylinder";
    case ShapeType::kConvex: return "convex";
    case ShapeType::kMesh: return "mesh";
  }
  return "unknown";
}

Shape makeSphere(double radius) {
  requirePositive(radius, "sphere radius");
  Shape s;
  s.type = ShapeType::kSphere;
  s.radius = radius;
  finish(s);
  requireShapeRange(s);
  return s;
}

Shape makeBox(const Eigen::Vector3d& size) {
  requirePositive(size.x(), "box size[0]");
  requirePositive(size.y(), "box size[1]");
  requirePositive(size.z(), "box size[2]");
  Shape s;
  s.type = ShapeType::kBox;
  s.half_extents = 0.5 * size;
  finish(s);
  requireShapeRange(s);
  return s;
}

Shape makeCapsule(double radius, double length) {
  requirePositive(radius, "capsule radius");
  // A capsule of zero segment length is a sphere: allowed, but never negative.
  if (!std::isfinite(length) || length < 0.0) {
    throw InvalidArgument("capsule length must be finite and >= 0, got " + formatNumber(length));
  }
  Shape s;
  s.type = ShapeType::kCapsule;
  s.radius = radius;
  s.half_length = 0.5 * length;
  finish(s);
  requireShapeRange(s);
  return s;
}

Shape makeCylinder(double radius, double length) {
  requirePositive(radius, "cylinder radius");
  requirePositive(length, "cylinder length");
  Shape s;
  s.type = ShapeType::kCylinder;
  s.radius = radius;
  s.half_length = 0.5 * length;
  finish(s);
  requireShapeRange(s);
  return s;
}

Shape makeConvex(std::vector<Eigen::Vector3d> points) {
  requireFinitePoints(points, "convex points");
  Shape s;
  s.type = ShapeType::kConvex;
  s.points = std::move(points);
  finish(s);
  requireShapeRange(s);
  return s;
}

Shape makeMesh(std::vector<Eigen::Vector3d> vertices, std::vector<std::array<int, 3>> triangles) {
  requireFinitePoints(vertices, "mesh vertices");
  if (triangles.empty()) throw InvalidArgument("mesh triangles must not be empty");
  const int n = static_cast<int>(vertices.size());
  for (size_t t = 0; t < triangles.size(); ++t) {
    for (int c = 0; c < 3; ++c) {
      const int idx = triangles[t][c];
      if (idx < 0 || idx >= n) {
        throw InvalidArgument("mesh triangles[" + std::to_string(t) + "][" + std::to_string(c) +
                              "] = " + std::to_string(idx) + " is out of range [0, " +
                              std::to_string(n) + ")");
      }
    }
  }
  Shape s;
  s.type = ShapeType::kMesh;
  s.points = std::move(vertices);
  s.triangles = std::move(triangles);
  finish(s);
  requireShapeRange(s);
  return s;
}

Shape makePointSet(std::vector<Eigen::Vector3d> points, double radius) {
  if (points.empty()) throw InvalidArgument("point set: no point");
  requireFinitePoints(points, "point set points");  // named as the caller's points, not the mesh's vertices
  if (!(std::isfinite(radius) && radius > 0.0)) {
    throw InvalidArgument("point set: radius must be finite and > 0, got " + formatNumber(radius));
  }
  requireSize(radius, "point set: radius");
  std::vector<std::array<int, 3>> triangles(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    const int k = static_cast<int>(i);
    triangles[i] = {k, k, k};
  }
  // Grown in place, as finish() would grow it (inflate would copy a sensor's points and
  // triangles once more, and finish() pass over them again): makeMesh's bounding radius is the
  // points' largest norm, the margin 0.
  Shape s = makeMesh(std::move(points), std::move(triangles));
  s.margin = radius;
  s.bounding_radius += radius;
  return s;
}

Shape makeBoxSet(const std::vector<Eigen::Vector3d>& centres, const Eigen::Vector3d& size) {
  if (centres.empty()) throw InvalidArgument("box set: no box");
  if (!(size.allFinite() && (size.array() > 0.0).all())) throw InvalidArgument("box set: sizes must be finite and > 0");
  requireFinitePoints(centres, "box set centres");
  const Eigen::Vector3d h = 0.5 * size;
  // The 12 triangles of a box's faces over its 8 corners (corner c: x sign bit 0, y bit 1, z bit 2).
  static const int kFaces[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                                    {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  std::vector<Eigen::Vector3d> vertices;
  std::vector<std::array<int, 3>> triangles;
  vertices.reserve(8 * centres.size());
  triangles.reserve(12 * centres.size());
  for (const Eigen::Vector3d& c : centres) {
    const int base = static_cast<int>(vertices.size());
    for (int corner = 0; corner < 8; ++corner) {
      vertices.push_back(c + Eigen::Vector3d(corner & 1 ? h.x() : -h.x(), corner & 2 ? h.y() : -h.y(),
                                             corner & 4 ? h.z() : -h.z()));
    }
    for (const auto& f : kFaces) triangles.push_back({base + f[0], base + f[1], base + f[2]});
  }
  return makeMesh(std::move(vertices), std::move(triangles));
}

Shape transformShape(const Shape& shape, const Eigen::Isometry3d& pose) {
  const Eigen::Matrix3d R = pose.linear();
  const Eigen::Vector3d t = pose.translation();
  if (!R.allFinite() || !t.allFinite()) throw InvalidArgument("transformShape: the pose is not finite");
  if (!(R.transpose() * R).isIdentity(1e-9) || R.determinant() < 0.0) {
    throw InvalidArgument("transformShape: the pose is not a rigid transform (rotation part not orthonormal)");
  }
  if (R.isIdentity(0.0) && t.isZero(0.0)) return shape;
  std::vector<Eigen::Vector3d> points;
  double rounding = shape.margin;
  switch (shape.type) {
    case ShapeType::kSphere:
      points.push_back(Eigen::Vector3d::Zero());
      rounding += shape.radius;
      break;
    case ShapeType::kCapsule:
      points.emplace_back(0.0, 0.0, -shape.half_length);
      points.emplace_back(0.0, 0.0, shape.half_length);
      rounding += shape.radius;
      break;
    case ShapeType::kBox:
      for (int k = 0; k < 8; ++k) {
        points.emplace_back((k & 1 ? 1 : -1) * shape.half_extents.x(), (k & 2 ? 1 : -1) * shape.half_extents.y(),
                            (k & 4 ? 1 : -1) * shape.half_extents.z());
      }
      break;
    case ShapeType::kCylinder: {
      constexpr int kSides = 24;
      const double kPiLocal = 3.14159265358979323846;
      const double r = shape.radius / std::cos(kPiLocal / kSides);  // the polygon's edges touch the circle
      for (int k = 0; k < kSides; ++k) {
        const double a = 2.0 * kPiLocal * k / kSides;
        for (double z : {-shape.half_length, shape.half_length}) points.emplace_back(r * std::cos(a), r * std::sin(a), z);
      }
      break;
    }
    case ShapeType::kConvex:
    case ShapeType::kMesh: points = shape.points; break;
  }
  for (auto& p : points) p = R * p + t;
  Shape out;
  if (shape.type == ShapeType::kMesh) {
    out = makeMesh(std::move(points), shape.triangles);
  } else {
    out = makeConvex(std::move(points));
  }
  return rounding > 0.0 ? inflate(out, rounding) : out;
}

Shape inflate(const Shape& shape, double padding) {
  if (!std::isfinite(padding) || padding < 0.0) {
    throw InvalidArgument("padding must be finite and >= 0, got " + formatNumber(padding));
  }
  requireSize(padding, "padding");
  Shape s = shape;
  s.margin += padding;
  finish(s);
  return s;
}

void validateShape(const Shape& s, const std::string& what) {
  try {
    switch (s.type) {
      case ShapeType::kSphere: requirePositive(s.radius, "sphere radius"); break;
      case ShapeType::kBox:
        requirePositive(s.half_extents.x(), "box half_extents[0]");
        requirePositive(s.half_extents.y(), "box half_extents[1]");
        requirePositive(s.half_extents.z(), "box half_extents[2]");
        break;
      case ShapeType::kCapsule:
        requirePositive(s.radius, "capsule radius");
        if (!std::isfinite(s.half_length) || s.half_length < 0.0) {
          throw InvalidArgument("capsule half_length must be finite and >= 0");
        }
        break;
      case ShapeType::kCylinder:
        requirePositive(s.radius, "cylinder radius");
        requirePositive(s.half_length, "cylinder half_length");
        break;
      case ShapeType::kConvex: requireFinitePoints(s.points, "convex points"); break;
      case ShapeType::kMesh: {
        requireFinitePoints(s.points, "mesh vertices");
        if (s.triangles.empty()) throw InvalidArgument("mesh triangles must not be empty");
        const int n = static_cast<int>(s.points.size());
        for (size_t t = 0; t < s.triangles.size(); ++t) {
          for (int c = 0; c < 3; ++c) {
            if (s.triangles[t][c] < 0 || s.triangles[t][c] >= n) {
              throw InvalidArgument("mesh triangles[" + std::to_string(t) + "][" + std::to_string(c) +
                                    "] is out of range [0, " + std::to_string(n) + ")");
            }
          }
        }
        break;
      }
    }
    if (!std::isfinite(s.margin) || s.margin < 0.0) {
      throw InvalidArgument("margin must be finite and >= 0, got " + formatNumber(s.margin));
    }
    requireShapeRange(s);
    Shape copy = s;
    finish(copy);
    if (!(std::abs(copy.bounding_radius - s.bounding_radius) <= 1e-12 * (1.0 + copy.bounding_radius))) {
      throw InvalidArgument("bounding_radius is stale (build shapes with the make* functions)");
    }
  } catch (const InvalidArgument& e) {
    throw InvalidArgument(what + ": " + e.what());
  }
}

double support(const Shape& s, const Eigen::Vector3d& d) {
  double h = 0.0;
  switch (s.type) {
    case ShapeType::kSphere: h = s.radius * d.norm(); break;
    case ShapeType::kBox: h = s.half_extents.dot(d.cwiseAbs()); break;
    case ShapeType::kCapsule: h = s.half_length * std::abs(d.z()) + s.radius * d.norm(); break;
    case ShapeType::kCylinder:
      // sqrt, not hypot: the magnitudes here cannot overflow, and hypot is several times slower.
      h = s.half_length * std::abs(d.z()) + s.radius * std::sqrt(d.x() * d.x() + d.y() * d.y());
      break;
    case ShapeType::kConvex:
    case ShapeType::kMesh: {
      h = -std::numeric_limits<double>::infinity();
      for (const auto& p : s.points) h = std::max(h, p.dot(d));
      break;
    }
  }
  return h + s.margin * d.norm();
}

Eigen::Vector3d supportPoint(const Shape& s, const Eigen::Vector3d& d) {
  const double dn = d.norm();
  const Eigen::Vector3d u = dn > 0.0 ? Eigen::Vector3d(d / dn) : Eigen::Vector3d::UnitZ();
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  auto sgn = [](double x) { return x >= 0.0 ? 1.0 : -1.0; };
  switch (s.type) {
    case ShapeType::kSphere: p = s.radius * u; break;
    case ShapeType::kBox:
      p = Eigen::Vector3d(sgn(u.x()) * s.half_extents.x(), sgn(u.y()) * s.half_extents.y(),
                          sgn(u.z()) * s.half_extents.z());
      break;
    case ShapeType::kCapsule: p = Eigen::Vector3d(0, 0, sgn(u.z()) * s.half_length) + s.radius * u; break;
    case ShapeType::kCylinder: {
      const double r = std::hypot(u.x(), u.y());
      p.z() = sgn(u.z()) * s.half_length;
      if (r > 0.0) {
        p.x() = s.radius * u.x() / r;
        p.y() = s.radius * u.y() / r;
      }
      break;
    }
    case ShapeType::kConvex:
    case ShapeType::kMesh: {
      double best = -std::numeric_limits<double>::infinity();
      for (const auto& q : s.points) {
        const double v = q.dot(u);
        if (v > best) {
          best = v;
          p = q;
        }
      }
      break;
    }
  }
  return p + s.margin * u;
}

}  // namespace vadop
