// AxisPool construction and the exact covering radius of an axis set.
//
// Covering radius: on the unit sphere the convex hull of the 2m points +-a_k is their
// spherical Delaunay triangulation, and each facet's outward normal is a Voronoi vertex whose
// distance to its nearest points is the facet's angular circumradius. The farthest any
// direction can be from its nearest point is attained at a Voronoi vertex, so the covering
// radius is the largest facet circumradius. The hull is built with exact predicates.
//
// Pool: antipodally symmetric starting sets (golden-angle lattices on the hemisphere, and
// icosahedral geodesic grids of nearby size with axes added or removed) are improved by two
// relaxations that keep the symmetry by moving one representative of each +-pair: a
// Chebyshev-centre Lloyd iteration, then a smoothed minimax descent on the circumradii. The
// set with the smallest covering radius seen is kept; it is never worse than the plain
// golden-angle lattice (fibonacciAxes).

#include "vadop/axis_pool.h"
#include "fibonacci_axes.h"

#include "vadop/error.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace vadop {
namespace {

using Vec3 = Eigen::Vector3d;
__extension__ typedef __int128 Int128;  // exact orientation tests, see GridPoint

constexpr double kPi = 3.14159265358979323846;

// Relaxation effort (measured: see the tests' report of covering radius against time).
constexpr int kLloydSteps = 8;
constexpr int kProbeSteps = 40;   // every start gets this many descent steps ...
constexpr int kSoftSteps = 200;   // ... and the chosen ones this many in all
// Small pools get extra, perturbed starts (about kExtraStartWork / (100 m) of them) and relax
// several starts to the end (about kFinalWork / (400 m)); the work is counted in point-steps,
// m times relaxation steps, at roughly a microsecond each.
constexpr int kExtraStartWork = 30000;
constexpr int kFinalWork = 50000;
constexpr int kMaxExtraStarts = 16;

// Deterministic on every platform (std::shuffle and the std distributions are not).
class SplitMix64 {
 public:
  explicit SplitMix64(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  std::uint64_t below(std::uint64_t n) { return next() % n; }  // the bias is irrelevant here

 private:
  std::uint64_t state_;
};

// ---------------------------------------------------------------------------------------
// Exact predicates.
//
// Hull decisions are made on the points rounded to a grid of 2^-40. Rounding moves a unit
// vector by < 1e-12, far below any tolerance a covering radius is used with, and in exchange
// every orientation test is exact: differences are < 2^41, a cross product < 2^83 and a
// triple product < 2^126, all inside a signed 128-bit integer. Exact signs mean the hull can
// never become topologically inconsistent, however cocircular (the cube, the octahedron) or
// nearly coincident the input is.
constexpr double kGridScale = 1099511627776.0;  // 2^40

struct GridPoint {
  std::int64_t x, y, z;
};

GridPoint toGrid(const Vec3& u) {  // u must be finite with |coordinates| <= 1
  return {std::llround(u.x() * kGridScale), std::llround(u.y() * kGridScale),
          std::llround(u.z() * kGridScale)};
}

void toGrid(const std::vector<Vec3>& points, std::vector<GridPoint>* grid) {
  grid->resize(points.size());
  for (size_t i = 0; i < points.size(); ++i) (*grid)[i] = toGrid(points[i]);
}

struct ExactNormal {
  Int128 x, y, z;
  bool isZero() const { return x == 0 && y == 0 && z == 0; }
  double magnitude() const {
    const double dx = static_cast<double>(x), dy = static_cast<double>(y),
                 dz = static_cast<double>(z);
    return std::sqrt(dx * dx + dy * dy + dz * dz);
  }
};

// (b - a) x (c - a): the outward normal when a, b, c are counter-clockwise seen from outside.
ExactNormal exactNormal(const GridPoint& a, const GridPoint& b, const GridPoint& c) {
  const Int128 ux = b.x - a.x, uy = b.y - a.y, uz = b.z - a.z;
  const Int128 vx = c.x - a.x, vy = c.y - a.y, vz = c.z - a.z;
  return {uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx};
}

int signOf(Int128 d) { return (d > 0) - (d < 0); }

// Sign of n . (q - a): +1 when q is strictly beyond the plane through a with normal n.
int exactSide(const ExactNormal& n, const GridPoint& a, const GridPoint& q) {
  return signOf(n.x * Int128(q.x - a.x) + n.y * Int128(q.y - a.y) + n.z * Int128(q.z - a.z));
}

// Sign of ((b - a) x (c - a)) . (d - a). A double evaluation decides whenever its value is
// far above its rounding error (differences of grid coordinates are exact in double, so only
// the products round: the error is below 4 * 2^-53 times the sum of absolute products); the
// rare near-coplanar cases fall through to the exact integer evaluation.
int orient(const GridPoint& a, const GridPoint& b, const GridPoint& c, const GridPoint& d) {
  const double ux = double(b.x - a.x), uy = double(b.y - a.y), uz = double(b.z - a.z);
  const double vx = double(c.x - a.x), vy = double(c.y - a.y), vz = double(c.z - a.z);
  const double wx = double(d.x - a.x), wy = double(d.y - a.y), wz = double(d.z - a.z);
  const double cx = uy * vz - uz * vy, cy = uz * vx - ux * vz, cz = ux * vy - uy * vx;
  const double det = cx * wx + cy * wy + cz * wz;
  const double bound = 1e-14 * ((std::fabs(uy * vz) + std::fabs(uz * vy)) * std::fabs(wx) +
                                (std::fabs(uz * vx) + std::fabs(ux * vz)) * std::fabs(wy) +
                                (std::fabs(ux * vy) + std::fabs(uy * vx)) * std::fabs(wz));
  if (det > bound) return 1;
  if (det < -bound) return -1;
  return exactSide(exactNormal(a, b, c), a, d);
}

// Sign of a . (b x c): +1 when the triangle a, b, c winds counter-clockwise seen from outside
// the origin, i.e. it faces away from the centre of the sphere.
int orientAroundOrigin(const GridPoint& a, const GridPoint& b, const GridPoint& c) {
  return orient(GridPoint{0, 0, 0}, a, b, c);
}

// ---------------------------------------------------------------------------------------
// A closed triangulated surface: triangles counter-clockwise seen from outside, nb[i] the
// triangle across the edge v[i] -> v[(i + 1) % 3].
struct MeshTriangle {
  int v[3];
  int nb[3];
};

// Incremental convex hull (randomised insertion with one conflict facet per pending point).
//
// Every pending point outside the current hull remembers one facet it sees. Inserting a point
// removes the connected region of facets it sees strictly and closes the hole with a cone to
// its horizon. The points that were waiting on a removed facet only need to be tested against
// the new cone facets: a point q beyond a removed facet f that is outside the new hull leaves
// it, on the segment from the interior of f to q, through a new facet (the old hull lies
// entirely behind f), so q is beyond a cone facet. Expected cost O(n log n).
//
// Ties: a point exactly in the plane of a facet does not see it. On the sphere such a point
// lies on that facet's circumcircle, so leaving it out of (or off the corner of) that facet
// does not change any empty circumcap and hence not the covering radius. Likewise a grid point
// that ends up inside the hull (a duplicate, or nearly cocircular with a facet) is on or within
// 1e-12 of that facet's circumcircle and is dropped for the same reason.
class SphereHull {
 public:
  // Returns false when the points span no volume (all coplanar), which for an antipodally
  // symmetric set means every axis lies on one great circle.
  bool build(const std::vector<GridPoint>& grid, std::vector<MeshTriangle>* out);

 private:
  struct Facet {
    int v[3];
    int nb[3];
    ExactNormal normal;
    int conflictHead;
    int stamp;
    bool visible;
    bool alive;
  };

  int addFacet(int a, int b, int c);
  bool findInitialTetrahedron(int* t) const;
  void attachConflict(int point, int facet);
  void insertPoint(int p, int step);
  // The steps of insertPoint: the facets p sees (from its conflict facet) and the horizon
  // edges around them; the horizon checked to be one simple cycle, each edge indexed by its
  // start vertex in horizonStart_; the cone of new facets from the horizon to p; the points
  // waiting on the visible facets moved to the new facets they see (or dropped as inside).
  void findHorizon(int p, int step);
  void checkHorizon();
  void addCone(int p);
  void reassignConflicts(int p);

  const std::vector<GridPoint>* grid_ = nullptr;
  std::vector<Facet> facets_;
  std::vector<int> conflictFacet_;  // -1: not pending (inserted, inside, or a duplicate)
  std::vector<int> conflictNext_;   // intrusive list of the points waiting on one facet
  std::vector<int> horizonStart_;   // scratch: index of the horizon edge starting at a vertex
  std::vector<int> visibleFacets_, stack_, newFacets_;
  std::vector<std::pair<int, int>> horizon_;  // (visible facet, edge index)
};

int SphereHull::addFacet(int a, int b, int c) {
  const std::vector<GridPoint>& g = *grid_;
  Facet f;
  f.v[0] = a;
  f.v[1] = b;
  f.v[2] = c;
  f.nb[0] = f.nb[1] = f.nb[2] = -1;
  f.normal = exactNormal(g[a], g[b], g[c]);
  f.conflictHead = -1;
  f.stamp = -1;
  f.visible = false;
  f.alive = true;
  facets_.push_back(f);
  return static_cast<int>(facets_.size()) - 1;
}

void SphereHull::attachConflict(int point, int facet) {
  conflictFacet_[point] = facet;
  if (facet >= 0) {
    conflictNext_[point] = facets_[facet].conflictHead;
    facets_[facet].conflictHead = point;
  }
}

bool SphereHull::findInitialTetrahedron(int* t) const {
  const std::vector<GridPoint>& g = *grid_;
  const int n = static_cast<int>(g.size());
  // Far-apart choices keep the first facets well shaped; exactness only needs non-zero.
  t[0] = 0;
  t[1] = -1;
  double best = 0.0;
  for (int i = 1; i < n; ++i) {
    const double dx = double(g[i].x - g[0].x), dy = double(g[i].y - g[0].y),
                 dz = double(g[i].z - g[0].z);
    const double d = dx * dx + dy * dy + dz * dz;
    if (d > best) {
      best = d;
      t[1] = i;
    }
  }
  if (t[1] < 0) return false;
  t[2] = -1;
  best = 0.0;
  for (int i = 1; i < n; ++i) {
    const ExactNormal c = exactNormal(g[t[0]], g[t[1]], g[i]);
    if (c.isZero()) continue;
    if (t[2] < 0 || c.magnitude() > best) {
      best = c.magnitude();
      t[2] = i;
    }
  }
  if (t[2] < 0) return false;
  const ExactNormal base = exactNormal(g[t[0]], g[t[1]], g[t[2]]);
  t[3] = -1;
  best = 0.0;
  for (int i = 1; i < n; ++i) {
    const Int128 d = base.x * Int128(g[i].x - g[t[0]].x) + base.y * Int128(g[i].y - g[t[0]].y) +
                     base.z * Int128(g[i].z - g[t[0]].z);
    if (d == 0) continue;
    const double ad = std::fabs(static_cast<double>(d));
    if (t[3] < 0 || ad > best) {
      best = ad;
      t[3] = i;
    }
  }
  return t[3] >= 0;
}

bool SphereHull::build(const std::vector<GridPoint>& grid, std::vector<MeshTriangle>* out) {
  out->clear();
  grid_ = &grid;
  const int n = static_cast<int>(grid.size());
  facets_.clear();
  facets_.reserve(static_cast<size_t>(8 * n + 16));
  conflictFacet_.assign(n, -1);
  conflictNext_.assign(n, -1);
  horizonStart_.assign(n, -1);
  if (n < 4) return false;

  int t[4];
  if (!findInitialTetrahedron(t)) return false;
  if (exactSide(exactNormal(grid[t[0]], grid[t[1]], grid[t[2]]), grid[t[0]], grid[t[3]]) > 0)
    std::swap(t[1], t[2]);
  // t[3] is now behind (t0, t1, t2); each other face is ordered so that its opposite vertex
  // is behind it too, which makes all four normals point outward.
  addFacet(t[0], t[1], t[2]);
  addFacet(t[0], t[3], t[1]);
  addFacet(t[1], t[3], t[2]);
  addFacet(t[2], t[3], t[0]);
  for (int f = 0; f < 4; ++f) {
    for (int i = 0; i < 3; ++i) {
      const int a = facets_[f].v[i], b = facets_[f].v[(i + 1) % 3];
      for (int h = 0; h < 4; ++h)
        for (int j = 0; j < 3; ++j)
          if (facets_[h].v[j] == b && facets_[h].v[(j + 1) % 3] == a) facets_[f].nb[i] = h;
    }
  }

  for (int q = 0; q < n; ++q) {
    if (q == t[0] || q == t[1] || q == t[2] || q == t[3]) continue;
    for (int f = 0; f < 4; ++f) {
      if (exactSide(facets_[f].normal, grid[facets_[f].v[0]], grid[q]) > 0) {
        attachConflict(q, f);
        break;
      }
    }
  }

  // Random insertion order (fixed seed) gives the expected O(n log n) bound.
  std::vector<int> order(n);
  for (int i = 0; i < n; ++i) order[i] = i;
  SplitMix64 rng(0x5EEDu + static_cast<std::uint64_t>(n));
  for (int i = n - 1; i > 0; --i) std::swap(order[i], order[rng.below(i + 1)]);
  int step = 0;
  for (int p : order)
    if (conflictFacet_[p] >= 0) insertPoint(p, step++);

  // Compact the live facets into the output, renumbering the neighbour links.
  std::vector<int> index(facets_.size(), -1);
  int live = 0;
  for (size_t f = 0; f < facets_.size(); ++f)
    if (facets_[f].alive) index[f] = live++;
  out->resize(live);
  for (size_t f = 0; f < facets_.size(); ++f) {
    if (!facets_[f].alive) continue;
    MeshTriangle& tri = (*out)[index[f]];
    for (int i = 0; i < 3; ++i) {
      tri.v[i] = facets_[f].v[i];
      tri.nb[i] = index[facets_[f].nb[i]];
    }
  }
  return true;
}

void SphereHull::insertPoint(int p, int step) {
  findHorizon(p, step);
  checkHorizon();
  addCone(p);
  reassignConflicts(p);
  conflictFacet_[p] = -1;
}

void SphereHull::findHorizon(int p, int step) {
  const std::vector<GridPoint>& g = *grid_;
  const GridPoint& gp = g[p];
  visibleFacets_.clear();
  horizon_.clear();
  stack_.clear();
  const int start = conflictFacet_[p];
  facets_[start].stamp = step;
  facets_[start].visible = true;
  stack_.push_back(start);
  while (!stack_.empty()) {
    const int f = stack_.back();
    stack_.pop_back();
    visibleFacets_.push_back(f);
    for (int i = 0; i < 3; ++i) {
      const int h = facets_[f].nb[i];
      Facet& fh = facets_[h];
      if (fh.stamp != step) {
        fh.stamp = step;
        fh.visible = exactSide(fh.normal, g[fh.v[0]], gp) > 0;
        if (fh.visible) stack_.push_back(h);
      }
      if (!fh.visible) horizon_.emplace_back(f, i);
    }
  }
}

void SphereHull::checkHorizon() {
  // With exact signs the strictly visible region of a convex polytope is a disc (around any
  // vertex the visible facets are those whose normals lie in an open hemisphere, a contiguous
  // run of the convex cycle of normals), so its boundary is one simple cycle. A violation is
  // a bug, not bad input.
  const int hs = static_cast<int>(horizon_.size());
  for (int k = 0; k < hs; ++k) {
    const int a = facets_[horizon_[k].first].v[horizon_[k].second];
    if (horizonStart_[a] >= 0) throw std::logic_error("SphereHull: horizon is not simple");
    horizonStart_[a] = k;
  }
  {
    int k = 0, length = 0;
    do {
      const Facet& f = facets_[horizon_[k].first];
      k = horizonStart_[f.v[(horizon_[k].second + 1) % 3]];
      ++length;
    } while (k > 0 && length <= hs);
    if (k != 0 || length != hs) throw std::logic_error("SphereHull: horizon is not one cycle");
  }
}

void SphereHull::addCone(int p) {
  const int hs = static_cast<int>(horizon_.size());
  newFacets_.resize(hs);
  for (int k = 0; k < hs; ++k) {
    const int f = horizon_[k].first, i = horizon_[k].second;
    const int a = facets_[f].v[i], b = facets_[f].v[(i + 1) % 3], h = facets_[f].nb[i];
    const int nf = addFacet(a, b, p);  // may reallocate: index facets_ afresh after this
    newFacets_[k] = nf;
    facets_[nf].nb[0] = h;
    for (int j = 0; j < 3; ++j)
      if (facets_[h].nb[j] == f && facets_[h].v[j] == b) facets_[h].nb[j] = nf;
  }
  for (int k = 0; k < hs; ++k) {
    const int nf = newFacets_[k];
    const int next = newFacets_[horizonStart_[facets_[nf].v[1]]];
    facets_[nf].nb[1] = next;  // edge b -> p is shared with the cone facet starting at b,
    facets_[next].nb[2] = nf;  // whose edge p -> b is its reverse
  }
  for (int k = 0; k < hs; ++k) horizonStart_[facets_[newFacets_[k]].v[0]] = -1;
}

void SphereHull::reassignConflicts(int p) {
  const std::vector<GridPoint>& g = *grid_;
  const GridPoint& gp = g[p];
  for (int f : visibleFacets_) {
    facets_[f].alive = false;
    int q = facets_[f].conflictHead;
    facets_[f].conflictHead = -1;
    while (q >= 0) {
      const int next = conflictNext_[q];
      int target = -1;
      if (q != p) {
        for (int nf : newFacets_) {
          if (exactSide(facets_[nf].normal, gp, g[q]) > 0) {  // p is a vertex of nf
            target = nf;
            break;
          }
        }
      }
      attachConflict(q, target);
      q = next;
    }
  }
}

// ---------------------------------------------------------------------------------------
// Repairing the hull after the points moved a little (the relaxation moves every point at
// every step, and rebuilding from scratch would cost most of the time).
//
// If every triangle still faces away from the origin, the surface is a sphere star-shaped
// around the origin. Flipping a reflex edge (the far vertex strictly beyond a triangle's
// plane) adds the tetrahedron of the two triangles to the enclosed volume, so flipping
// terminates, and a star-shaped closed surface without reflex edges is convex: it is the hull.
// Returns false, leaving `mesh` in an unspecified state, whenever this argument does not apply
// (an inverted triangle, a flip that would invert one or collapse a degree-3 vertex); the
// caller then rebuilds the hull.
bool restoreConvexity(const std::vector<GridPoint>& g, std::vector<MeshTriangle>* mesh,
                      std::vector<std::pair<int, int>>* stack) {
  std::vector<MeshTriangle>& t = *mesh;
  const int nt = static_cast<int>(t.size());
  for (const MeshTriangle& tri : t)
    if (orientAroundOrigin(g[tri.v[0]], g[tri.v[1]], g[tri.v[2]]) <= 0) return false;
  stack->clear();
  for (int f = 0; f < nt; ++f)
    for (int i = 0; i < 3; ++i)
      if (f < t[f].nb[i]) stack->emplace_back(f, i);  // each edge once
  long flips = 0;
  const long maxFlips = 64L * nt + 64;  // termination is guaranteed; this only guards bugs
  while (!stack->empty()) {
    const int f = stack->back().first, i = stack->back().second;
    stack->pop_back();
    const int a = t[f].v[i], b = t[f].v[(i + 1) % 3], c = t[f].v[(i + 2) % 3];
    const int u = t[f].nb[i];
    int j = 0;
    while (j < 3 && t[u].v[j] != b) ++j;
    if (j == 3 || t[u].v[(j + 1) % 3] != a) return false;  // inconsistent links: rebuild
    const int d = t[u].v[(j + 2) % 3];
    if (orient(g[a], g[b], g[c], g[d]) <= 0) continue;  // convex or flat: fine
    // f = (a, b, c) and u = (b, a, d) become (c, a, d) and (d, b, c).
    const int fa = t[f].nb[(i + 2) % 3];  // across c -> a
    const int fb = t[f].nb[(i + 1) % 3];  // across b -> c
    const int ua = t[u].nb[(j + 1) % 3];  // across a -> d
    const int ub = t[u].nb[(j + 2) % 3];  // across d -> b
    if (fa == ua || fb == ub) return false;  // a or b has degree 3
    if (orientAroundOrigin(g[c], g[a], g[d]) <= 0 || orientAroundOrigin(g[d], g[b], g[c]) <= 0)
      return false;
    if (++flips > maxFlips) return false;
    t[f] = MeshTriangle{{c, a, d}, {fa, ua, u}};
    t[u] = MeshTriangle{{d, b, c}, {ub, fb, f}};
    for (int k = 0; k < 3; ++k) {
      if (t[ua].nb[k] == u) t[ua].nb[k] = f;
      if (t[fb].nb[k] == f) t[fb].nb[k] = u;
    }
    stack->emplace_back(f, 0);
    stack->emplace_back(f, 1);
    stack->emplace_back(u, 0);
    stack->emplace_back(u, 1);
  }
  return true;
}

// ---------------------------------------------------------------------------------------
// Geometry of the symmetric set +-x_k.

// Angular circumradius of a hull facet: the angle from its outward normal (the circumcentre
// direction, a Voronoi vertex) to its vertices. Computed from the unrounded unit vectors.
double facetCircumradius(const Vec3& a, const Vec3& b, const Vec3& c, Vec3* centre) {
  Vec3 n = (b - a).cross(c - a);
  const double len = n.norm();
  if (!(len > 0.0)) {  // cannot happen for a hull facet; be conservative if it ever does
    if (centre) *centre = a;
    return kPi / 2;
  }
  n /= len;
  if (centre) *centre = n;
  double r = 0.0;
  for (const Vec3* v : {&a, &b, &c}) r = std::max(r, std::atan2(n.cross(*v).norm(), n.dot(*v)));
  return r;
}

void withAntipodes(const std::vector<Vec3>& axes, std::vector<Vec3>* points) {
  const size_t m = axes.size();
  points->resize(2 * m);
  for (size_t k = 0; k < m; ++k) {
    (*points)[k] = axes[k];
    (*points)[k + m] = -axes[k];
  }
}

// Covering radius of validated unit axes.
double coveringRadiusOfUnitAxes(const std::vector<Vec3>& unitAxes) {
  std::vector<Vec3> points;
  withAntipodes(unitAxes, &points);
  std::vector<GridPoint> grid;
  toGrid(points, &grid);
  std::vector<MeshTriangle> mesh;
  SphereHull hull;
  // All axes on one great circle: the normal of that circle is 90 degrees from every axis
  // and no direction can be farther, so the covering radius is exactly pi/2.
  if (!hull.build(grid, &mesh)) return kPi / 2;
  double rho = 0.0;
  for (const MeshTriangle& t : mesh)
    rho = std::max(rho, facetCircumradius(points[t.v[0]], points[t.v[1]], points[t.v[2]], nullptr));
  return rho;
}

// Upper half-space representative: z > 0; on the rim y > 0; on the rim's x axis x > 0.
Vec3 canonicalAxis(const Vec3& a) {
  const bool flip =
      a.z() < 0.0 || (a.z() == 0.0 && (a.y() < 0.0 || (a.y() == 0.0 && a.x() < 0.0)));
  return flip ? Vec3(-a) : a;
}

// Golden-angle lattice on the upper hemisphere at heights (k + offset) / m: equal-area bands,
// so together with the antipodes the whole sphere is sampled evenly.
std::vector<Vec3> goldenLattice(int m, double offset) {
  const double goldenAngle = kPi * (3.0 - std::sqrt(5.0));
  std::vector<Vec3> axes(m);
  for (int k = 0; k < m; ++k) {
    const double z = std::min(1.0, (k + offset) / m);
    const double s = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = goldenAngle * k;
    axes[k] = canonicalAxis(Vec3(s * std::cos(phi), s * std::sin(phi), z).normalized());
  }
  return axes;
}

// Icosahedral geodesic points, one of each antipodal pair. Subdividing every face of the
// icosahedron into a triangular lattice of `frequency` segments per edge leaves all points
// with six neighbours except the twelve vertices; with `classTwo` only the index-3 sublattice
// rotated by 30 degrees is kept (barycentric i - j divisible by 3), which is the same kind of
// grid at a third of the density. These two families are the only geodesic grids that are
// antipodally symmetric (x -> -x is a rotation composed with a mirror, and the chiral grids
// have no mirror symmetry); they have 5 a^2 + 1 and 15 a^2 + 1 axes. Returns an empty set if
// the fixed generic rotation that keeps points off the rim ever failed to.
std::vector<Vec3> icosahedralAxes(int frequency, bool classTwo) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Vec3> v;
  for (double s1 : {-1.0, 1.0})
    for (double s2 : {-1.0, 1.0}) {
      v.push_back(Vec3(0.0, s1, s2 * t).normalized());
      v.push_back(Vec3(s1, s2 * t, 0.0).normalized());
      v.push_back(Vec3(s2 * t, 0.0, s1).normalized());
    }
  double edge = 4.0;  // the shortest distance between vertices
  for (int a = 0; a < 12; ++a)
    for (int b = a + 1; b < 12; ++b) edge = std::min(edge, (v[a] - v[b]).norm());
  auto adjacent = [&](int a, int b) { return std::fabs((v[a] - v[b]).norm() - edge) < 1e-9; };
  const int nu = classTwo ? 3 * frequency : frequency;
  auto keep = [&](int i, int j) { return !classTwo || (i - j) % 3 == 0; };
  std::vector<Vec3> points(v);
  for (int a = 0; a < 12; ++a)
    for (int b = a + 1; b < 12; ++b) {
      if (!adjacent(a, b)) continue;
      for (int i = 1; i < nu; ++i)  // edge points, once per edge
        if (keep(i, nu - i)) points.push_back((i * v[a] + (nu - i) * v[b]).normalized());
      for (int c = b + 1; c < 12; ++c) {
        if (!adjacent(a, c) || !adjacent(b, c)) continue;
        for (int i = 1; i < nu; ++i)  // face interior points, once per face
          for (int j = 1; i + j < nu; ++j)
            if (keep(i, j))
              points.push_back((i * v[a] + j * v[b] + (nu - i - j) * v[c]).normalized());
      }
    }
  const Eigen::Matrix3d rotation =
      Eigen::AngleAxisd(0.3, Vec3(1.0, 2.0, 3.0).normalized()).toRotationMatrix();
  std::vector<Vec3> axes;
  for (const Vec3& p : points) {
    const Vec3 q = rotation * p;
    if (q.z() > 0.0) axes.push_back(q);
  }
  if (2 * axes.size() != points.size()) return {};
  return axes;
}

// Adds or removes axes to reach m, spread evenly: the changes are made nearest to the points
// of a golden-angle lattice of as many axes as are added or removed. Added axes go to
// Voronoi vertices (the holes of the covering), removed ones are the nearest existing axes.
std::vector<Vec3> adjustedAxisCount(std::vector<Vec3> axes, int m) {
  const int have = static_cast<int>(axes.size());
  if (have > m) {
    for (const Vec3& target : goldenLattice(have - m, 0.5)) {
      size_t nearest = 0;
      for (size_t k = 1; k < axes.size(); ++k)
        if (std::fabs(axes[k].dot(target)) > std::fabs(axes[nearest].dot(target))) nearest = k;
      axes.erase(axes.begin() + static_cast<std::ptrdiff_t>(nearest));
    }
  } else if (have < m) {
    std::vector<Vec3> points;
    withAntipodes(axes, &points);
    std::vector<GridPoint> grid;
    toGrid(points, &grid);
    std::vector<MeshTriangle> mesh;
    SphereHull hull;
    if (!hull.build(grid, &mesh)) return {};
    std::vector<Vec3> holes;  // one of each antipodal pair of Voronoi vertices
    for (const MeshTriangle& t : mesh) {
      Vec3 centre;
      facetCircumradius(points[t.v[0]], points[t.v[1]], points[t.v[2]], &centre);
      if (centre.z() > 0.0) holes.push_back(centre);
    }
    std::vector<char> used(holes.size(), 0);
    for (const Vec3& target : goldenLattice(m - have, 0.5)) {
      int nearest = -1;
      for (size_t f = 0; f < holes.size(); ++f)
        if (!used[f] && (nearest < 0 || std::fabs(holes[f].dot(target)) >
                                            std::fabs(holes[nearest].dot(target))))
          nearest = static_cast<int>(f);
      if (nearest < 0) return {};
      used[nearest] = 1;
      axes.push_back(holes[nearest]);
    }
  }
  return axes;
}

// Smallest spherical cap containing unit vectors that all lie well inside one hemisphere
// (here: the Voronoi vertices of one cell, within the covering radius < 90 degrees of its
// site). Returns the cap's centre. Incremental construction with the boundary fixed by one,
// two, then three points; on the sphere the caps through two or three points are the
// normalised midpoint and the plane normal, just as circles are in the plane.
Vec3 smallestEnclosingCapCentre(const std::vector<Vec3>& s) {
  const double slack = 1e-14;  // in cosine
  Vec3 c = s[0];
  double cosR = 1.0;
  for (size_t i = 1; i < s.size(); ++i) {
    if (c.dot(s[i]) >= cosR - slack) continue;
    c = s[i];
    cosR = 1.0;
    for (size_t j = 0; j < i; ++j) {
      if (c.dot(s[j]) >= cosR - slack) continue;
      c = (s[i] + s[j]).normalized();
      cosR = c.dot(s[i]);
      for (size_t k = 0; k < j; ++k) {
        if (c.dot(s[k]) >= cosR - slack) continue;
        Vec3 n = (s[j] - s[i]).cross(s[k] - s[i]);
        if (!(n.norm() > 0.0)) continue;  // coincident vertices: already covered
        n.normalize();
        if (n.dot(s[i]) < 0.0) n = -n;
        c = n;
        cosR = std::min({n.dot(s[i]), n.dot(s[j]), n.dot(s[k])});
      }
    }
  }
  return c;
}

// ---------------------------------------------------------------------------------------
// Covering relaxation of m axes. Point k of the symmetric set is axis k and point k + m its
// antipode; only the axes move, so every state is exactly antipodally symmetric.
class CoveringRelaxation {
 public:
  static constexpr int kInitialPower = 64;  // powers of two: see powerOfRatio
  static constexpr int kMaxPower = 1024;
  static constexpr int kPowerDoublingSteps = 50;
  static constexpr double kMomentum = 0.8;

  explicit CoveringRelaxation(const std::vector<Vec3>& axes);

  bool valid() const { return valid_; }  // false if the start spans no volume
  // Moves every axis to the centre of the smallest cap holding its Voronoi cell. With the
  // cells fixed no cell's farthest point gets farther, and re-assigning directions to their
  // nearest axis only shortens distances, so the covering radius never increases.
  void chebyshevLloyd(int iterations);
  // Descent on sum_f (r_f / rho)^q over the Delaunay circumradii r_f: for large q a smooth
  // stand-in for max_f r_f that also pulls on the nearly-worst triangles, so points around
  // the largest holes move towards them while the rest stay balanced. q starts at
  // kInitialPower and doubles every kPowerDoublingSteps steps up to kMaxPower. Repeated
  // calls continue where the last one stopped.
  void softMinimax(int iterations);

  double bestRho() const { return bestRho_; }
  const std::vector<Vec3>& bestAxes() const { return bestAxes_; }

 private:
  struct State {
    std::vector<Vec3> axes;
    std::vector<Vec3> points;
    std::vector<GridPoint> grid;
    std::vector<MeshTriangle> mesh;
    bool complete = false;     // every point is a hull vertex (flip repair is allowed)
    std::vector<Vec3> centre;  // per triangle: circumcentre direction (unit normal)
    std::vector<double> radius, cosRadius, sinRadius;
    double rho = 0.0;
  };

  bool evaluate(const State& from, State* to);  // to->axes set; false if no hull
  void measure(State* s) const;
  void remember(const State& s);
  // Returns the objective of `s`; fills grad_ and curvature_.
  double gradient(const State& s, int q, double ref);
  static double objective(const State& s, int q, double ref);

  int m_;
  bool valid_ = false;
  State current_, trial_;
  SphereHull hull_;
  std::vector<std::pair<int, int>> flipStack_;
  std::vector<Vec3> grad_;
  std::vector<double> curvature_;
  std::vector<Vec3> velocity_;  // momentum, tangent to the axes
  int softSteps_ = 0;
  int power_ = kInitialPower;
  double stepScale_ = 1.0;
  double bestRho_ = kPi;
  std::vector<Vec3> bestAxes_;
};

CoveringRelaxation::CoveringRelaxation(const std::vector<Vec3>& axes)
    : m_(static_cast<int>(axes.size())) {
  State empty;
  trial_.axes = axes;
  valid_ = evaluate(empty, &trial_);
  if (valid_) {
    std::swap(current_, trial_);
    remember(current_);
  }
}

// Like facetCircumradius, but measured to one vertex only: the optimiser runs this on every
// step, and the kept result is re-measured exactly at the end.
void CoveringRelaxation::measure(State* s) const {
  const size_t nt = s->mesh.size();
  s->centre.resize(nt);
  s->radius.resize(nt);
  s->cosRadius.resize(nt);
  s->sinRadius.resize(nt);
  s->rho = 0.0;
  for (size_t f = 0; f < nt; ++f) {
    const int* v = s->mesh[f].v;
    const Vec3& a = s->points[v[0]];
    Vec3 n = (s->points[v[1]] - a).cross(s->points[v[2]] - a);
    const double len = n.norm();
    n = len > 0.0 ? Vec3(n / len) : a;  // a zero-area hull facet cannot occur; stay finite
    s->centre[f] = n;
    s->cosRadius[f] = n.dot(a);
    s->sinRadius[f] = n.cross(a).norm();
    s->radius[f] = len > 0.0 ? std::atan2(s->sinRadius[f], s->cosRadius[f]) : kPi / 2;
    s->rho = std::max(s->rho, s->radius[f]);
  }
}

bool CoveringRelaxation::evaluate(const State& from, State* to) {
  withAntipodes(to->axes, &to->points);
  toGrid(to->points, &to->grid);
  bool repaired = false;
  if (from.complete) {
    to->mesh = from.mesh;
    repaired = restoreConvexity(to->grid, &to->mesh, &flipStack_);
  }
  if (repaired) {
    to->complete = true;
  } else {
    if (!hull_.build(to->grid, &to->mesh)) return false;
    // Euler: a triangulated sphere on V vertices has 2V - 4 triangles.
    to->complete = to->mesh.size() == 2 * to->points.size() - 4;
  }
  measure(to);
  return true;
}

void CoveringRelaxation::remember(const State& s) {
  if (s.rho < bestRho_) {
    bestRho_ = s.rho;
    bestAxes_ = s.axes;
  }
}

void CoveringRelaxation::chebyshevLloyd(int iterations) {
  if (!valid_) return;
  std::vector<int> start, cells;
  std::vector<Vec3> cell;
  for (int it = 0; it < iterations; ++it) {
    const State& s = current_;
    // Voronoi vertices of axis k: circumcentres of the triangles at k, and the mirrored ones
    // at its antipode (the same cell reflected; listing both costs nothing).
    start.assign(m_ + 1, 0);
    for (const MeshTriangle& t : s.mesh)
      for (int v : t.v) ++start[v % m_ + 1];
    for (int k = 0; k < m_; ++k) start[k + 1] += start[k];
    cells.resize(start[m_]);
    std::vector<int> fill(start.begin(), start.end() - 1);
    for (size_t f = 0; f < s.mesh.size(); ++f)
      for (int v : s.mesh[f].v) cells[fill[v % m_]++] = static_cast<int>(2 * f) + (v >= m_);
    trial_.axes.resize(m_);
    for (int k = 0; k < m_; ++k) {
      cell.clear();
      for (int e = start[k]; e < start[k + 1]; ++e) {
        const Vec3& c = s.centre[cells[e] / 2];
        cell.push_back((cells[e] & 1) ? Vec3(-c) : c);
      }
      trial_.axes[k] = cell.empty() ? s.axes[k] : smallestEnclosingCapCentre(cell);
    }
    if (!evaluate(current_, &trial_)) return;
    if (trial_.rho > current_.rho * (1.0 + 1e-12)) return;  // converged to rounding noise
    std::swap(current_, trial_);
    remember(current_);
  }
}

// (r / ref)^q for q a power of two, by squaring; terms below 1e-200 are dropped as zero
// (they are, next to the worst triangle's 1) and that also keeps clear of denormals.
double powerOfRatio(double r, double ref, int q) {
  double p = r / ref;
  for (int e = 1; e < q; e *= 2) {
    p *= p;
    if (p < 1e-200) return 0.0;
  }
  return p;
}

double CoveringRelaxation::objective(const State& s, int q, double ref) {
  double sum = 0.0;
  for (double r : s.radius) sum += powerOfRatio(r, ref, q);
  return sum;
}

// Gradient of sum_f phi(r_f), phi(r) = (r / ref)^q, with respect to each axis (tangent to the
// sphere), and a diagonal Gauss-Newton curvature sum_f phi''(r_f) |grad r_f|^2 per axis that
// scales each axis' step. For a triangle a, b, c with N = (b - a) x (c - a) the cosine of the
// circumradius is h = det(a, b, c) / |N|, whence
//   dh/da = (b x c - h (b - c) x N/|N|) / |N|   (and cyclically for b and c),
// and dr = -dh / sin r. The antipode of axis k moves by the negated displacement.
double CoveringRelaxation::gradient(const State& s, int q, double ref) {
  grad_.assign(m_, Vec3::Zero());
  curvature_.assign(m_, 0.0);
  double sum = 0.0;
  for (size_t f = 0; f < s.mesh.size(); ++f) {
    const double r = s.radius[f];
    const double phi = powerOfRatio(r, ref, q);
    sum += phi;
    if (phi == 0.0) continue;
    const int* v = s.mesh[f].v;
    const Vec3& a = s.points[v[0]];
    const Vec3& b = s.points[v[1]];
    const Vec3& c = s.points[v[2]];
    const double len = (b - a).cross(c - a).norm();
    const double sinR = s.sinRadius[f];
    if (!(len > 0.0) || !(sinR > 0.0)) continue;
    const Vec3& nh = s.centre[f];
    const double h = s.cosRadius[f];
    const double dPhi = q * phi / r, ddPhi = q * (q - 1.0) * phi / (r * r);
    const double drdh = -1.0 / (sinR * len);
    const Vec3 dr[3] = {drdh * (b.cross(c) - h * (b - c).cross(nh)),
                        drdh * (c.cross(a) - h * (c - a).cross(nh)),
                        drdh * (a.cross(b) - h * (a - b).cross(nh))};
    for (int i = 0; i < 3; ++i) {
      const Vec3& p = s.points[v[i]];
      const Vec3 t = dr[i] - dr[i].dot(p) * p;
      const int k = v[i] % m_;
      grad_[k] += (v[i] < m_ ? dPhi : -dPhi) * t;
      curvature_[k] += ddPhi * t.squaredNorm();
    }
  }
  return sum;
}

void CoveringRelaxation::softMinimax(int iterations) {
  if (!valid_) return;
  velocity_.resize(m_, Vec3::Zero());
  for (int it = 0; it < iterations; ++it, ++softSteps_) {
    if (softSteps_ > 0 && softSteps_ % kPowerDoublingSteps == 0)
      power_ = std::min(kMaxPower, 2 * power_);
    const int q = power_;
    const double ref = current_.rho;
    const double value = gradient(current_, q, ref);
    trial_.axes.resize(m_);
    for (int k = 0; k < m_; ++k) {
      const Vec3 move = curvature_[k] > 0.0 ? Vec3(-stepScale_ / curvature_[k] * grad_[k])
                                            : Vec3::Zero();
      velocity_[k] = kMomentum * velocity_[k] + move;  // tentative, kept only on success
      trial_.axes[k] = (current_.axes[k] + velocity_[k]).normalized();
    }
    const bool ok = evaluate(current_, &trial_) &&
                    objective(trial_, q, ref) < value;
    if (ok) {
      for (int k = 0; k < m_; ++k) {
        const Vec3& x = trial_.axes[k];
        velocity_[k] -= velocity_[k].dot(x) * x;
      }
      std::swap(current_, trial_);
      remember(current_);
      stepScale_ = std::min(1.0, 1.5 * stepScale_);
    } else {
      std::fill(velocity_.begin(), velocity_.end(), Vec3::Zero());
      stepScale_ *= 0.5;
      if (stepScale_ < 1e-6) return;  // stalled
    }
  }
}

// Starting sets for m axes. The golden-angle lattice works for every m but carries many
// lattice defects (points with 5 or 7 neighbours where its spiral families change), which
// the relaxation cannot remove; an icosahedral geodesic grid has only its 12 unavoidable
// 5-neighbour points and relaxes to clearly better coverings (about 1.01-1.02 times the
// hexagonal bound against 1.03-1.06), so grids whose size is a little below m (axes added)
// or very little above (axes removed; removal disturbs a grid more) are tried too. Small
// pools have few, very different local optima, so they get extra, perturbed lattices.
std::vector<std::vector<Vec3>> startingSets(int m) {
  std::vector<std::vector<Vec3>> starts;
  starts.push_back(goldenLattice(m, 0.5));
  int below = 0, above = 0;  // nearest grid sizes, and their (frequency, class two)
  std::pair<int, bool> belowGrid, aboveGrid;
  for (int two = 0; two < 2; ++two) {
    for (int a = 1;; ++a) {
      const int size = (two ? 15 : 5) * a * a + 1;
      if (size <= m && size > below) {
        below = size;
        belowGrid = {a, two != 0};
      }
      if (size >= m) {
        if (above == 0 || size < above) {
          above = size;
          aboveGrid = {a, two != 0};
        }
        break;
      }
    }
  }
  auto addGrid = [&](std::pair<int, bool> grid) {
    std::vector<Vec3> axes = icosahedralAxes(grid.first, grid.second);
    if (!axes.empty()) axes = adjustedAxisCount(std::move(axes), m);
    if (static_cast<int>(axes.size()) == m) starts.push_back(std::move(axes));
  };
  if (below > 0 && m - below <= 0.12 * m) addGrid(belowGrid);
  if (above != below && above - m <= 0.025 * m) addGrid(aboveGrid);
  const int extra = std::clamp(kExtraStartWork / (100 * m) - 1, 0, kMaxExtraStarts);
  SplitMix64 rng(0xC0FFEEu + static_cast<std::uint64_t>(m));
  const double spacing = std::sqrt(2.0 * kPi / m);
  for (int e = 0; e < extra; ++e) {
    std::vector<Vec3> axes = goldenLattice(m, (e % 4 + 0.5) / 4.0);
    for (Vec3& a : axes) {
      Vec3 shift;
      for (int i = 0; i < 3; ++i) shift[i] = double(rng.below(1u << 20)) / double(1u << 19) - 1.0;
      a = canonicalAxis((a + 0.3 * spacing * shift).normalized());
    }
    starts.push_back(std::move(axes));
  }
  return starts;
}

// Every start is relaxed briefly; the most promising one (after the probe the ranking rarely
// changes any more) is relaxed to the end, or all of them for small pools, where it is cheap.
std::vector<Vec3> relaxedAxes(int m) {
  const std::vector<std::vector<Vec3>> starts = startingSets(m);
  std::vector<CoveringRelaxation> runs;
  runs.reserve(starts.size());
  for (const std::vector<Vec3>& start : starts) {
    runs.emplace_back(start);
    runs.back().chebyshevLloyd(kLloydSteps);
    runs.back().softMinimax(kProbeSteps);
  }
  std::vector<size_t> order(runs.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return runs[a].bestRho() < runs[b].bestRho();
  });
  const size_t finals = std::clamp<size_t>(kFinalWork / (400 * m), 1, runs.size());
  std::vector<Vec3> best = starts[0];  // the plain golden lattice: the result is never worse
  double bestRho = coveringRadiusOfUnitAxes(best);
  for (size_t i = 0; i < finals; ++i) {
    CoveringRelaxation& run = runs[order[i]];
    run.softMinimax(kSoftSteps - kProbeSteps);
    if (!run.valid()) continue;
    std::vector<Vec3> axes = run.bestAxes();
    for (Vec3& a : axes) a = canonicalAxis(a.normalized());
    const double rho = coveringRadiusOfUnitAxes(axes);
    if (rho < bestRho) {
      bestRho = rho;
      best = std::move(axes);
    }
  }
  return best;
}

}  // namespace

// ---------------------------------------------------------------------------------------

double coveringRadius(const std::vector<Vec3>& axes) {
  if (axes.size() < 3) {
    std::ostringstream msg;
    msg << "coveringRadius: need at least 3 axes, got " << axes.size();
    throw InvalidArgument(msg.str());
  }
  std::vector<Vec3> unit(axes.size());
  for (size_t k = 0; k < axes.size(); ++k) {
    const Vec3& a = axes[k];
    if (!a.allFinite()) {
      std::ostringstream msg;
      msg << "coveringRadius: axis " << k << " is not finite (" << a.x() << ", " << a.y()
          << ", " << a.z() << ")";
      throw InvalidArgument(msg.str());
    }
    const double scale = a.cwiseAbs().maxCoeff();  // scaling first avoids overflow in norm()
    if (!(scale > 0.0)) {
      std::ostringstream msg;
      msg << "coveringRadius: axis " << k << " is the zero vector";
      throw InvalidArgument(msg.str());
    }
    unit[k] = (a / scale).normalized();
  }
  return coveringRadiusOfUnitAxes(unit);
}

std::vector<Vec3> fibonacciAxes(int m) {
  if (m < 1) {
    std::ostringstream msg;
    msg << "fibonacciAxes: m = " << m << " must be positive";
    throw InvalidArgument(msg.str());
  }
  return goldenLattice(m, 0.5);
}

AxisPool::AxisPool(int m) {
  if (m < 3 || m > kMaxAxes) {
    std::ostringstream msg;
    msg << "AxisPool: m = " << m << " is outside [3, " << kMaxAxes << "]";
    throw InvalidArgument(msg.str());
  }
  if (m == 3) {  // optimal, and the pool the rest of the library may assume for m = 3
    axes_ = {Vec3::UnitX(), Vec3::UnitY(), Vec3::UnitZ()};
  } else {
    axes_ = relaxedAxes(m);
  }
  rho_ = vadop::coveringRadius(axes_);  // bit for bit what coveringRadius(axes()) returns
}

}  // namespace vadop
