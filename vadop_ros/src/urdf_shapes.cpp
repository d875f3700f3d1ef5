#include "vadop_ros/urdf_shapes.h"

#include <vadop/error.h>

#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <console_bridge/console.h>
#include <ros/package.h>
#include <urdf_parser/urdf_parser.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <map>
#include <memory>
#include <mutex>
#include <sstream>
#include <tuple>

namespace vadop_ros {
namespace {

// Collects urdfdom's error messages (it reports why a URDF does not parse through
// console_bridge only) while a parse runs.
class CaptureErrors : public console_bridge::OutputHandler {
 public:
  CaptureErrors() { console_bridge::useOutputHandler(this); }
  ~CaptureErrors() override { console_bridge::restorePreviousOutputHandler(); }
  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override {
    if (level >= console_bridge::CONSOLE_BRIDGE_LOG_ERROR) {
      if (!text_.empty()) text_ += "; ";
      text_ += text;
    }
  }
  const std::string& text() const { return text_; }

 private:
  std::string text_;
};

Eigen::Isometry3d toEigen(const urdf::Pose& p) {
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  Eigen::Quaterniond q(p.rotation.w, p.rotation.x, p.rotation.y, p.rotation.z);
  if (q.norm() < 1e-9) q = Eigen::Quaterniond::Identity();
  out.linear() = q.normalized().toRotationMatrix();
  out.translation() = Eigen::Vector3d(p.position.x, p.position.y, p.position.z);
  return out;
}

bool finitePose(const Eigen::Isometry3d& p) { return p.matrix().allFinite(); }

std::string extensionOf(const std::string& uri) {
  const size_t dot = uri.find_last_of('.');
  const size_t slash = uri.find_last_of('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  return uri.substr(dot + 1);
}

std::string limitText() {
  return std::to_string(kMaxMeshBytes >> 20) + " MiB";
}

// Reads a regular file of at most kMaxMeshBytes. The checks come before any byte is read (and
// again on the open descriptor): a device (/dev/zero), a FIFO or a directory is refused, as is
// a file larger than the limit; a file that grows while it is read stops at the limit.
std::vector<char> readBounded(const std::string& uri, const std::string& path) {
  const std::string what = "mesh \"" + uri + "\"";
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    throw std::runtime_error("cannot retrieve " + what + ": " + path + ": " + std::strerror(errno));
  }
  auto checkStat = [&](const struct stat& s) {
    if (!S_ISREG(s.st_mode)) throw std::runtime_error(what + ": " + path + " is not a regular file");
    if (static_cast<unsigned long long>(s.st_size) > kMaxMeshBytes) {
      throw std::runtime_error(what + " is " + std::to_string(static_cast<unsigned long long>(s.st_size)) +
                               " bytes, more than the limit of " + limitText() + " (kMaxMeshBytes)");
    }
  };
  checkStat(st);
  // O_NONBLOCK: should the path have become a FIFO since stat, open does not wait for a writer.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) throw std::runtime_error("cannot retrieve " + what + ": " + path + ": " + std::strerror(errno));
  std::unique_ptr<int, void (*)(int*)> closer(new int(fd), [](int* f) {
    ::close(*f);
    delete f;
  });
  if (::fstat(fd, &st) != 0) throw std::runtime_error("cannot retrieve " + what + ": " + std::strerror(errno));
  checkStat(st);
  std::vector<char> data(static_cast<size_t>(st.st_size) + 1);  // one more: detects growth
  size_t got = 0;
  while (got < data.size()) {
    const ssize_t n = ::read(fd, data.data() + got, data.size() - got);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw std::runtime_error("cannot read " + what + ": " + std::strerror(errno));
    if (n == 0) break;
    got += static_cast<size_t>(n);
  }
  if (got > kMaxMeshBytes) {
    throw std::runtime_error(what + " grew beyond the limit of " + limitText() + " (kMaxMeshBytes) while read");
  }
  data.resize(got);
  return data;
}

}  // namespace

std::string meshPath(const std::string& uri) {
  const std::string file = "file://", package = "package://";
  if (uri.compare(0, file.size(), file) == 0) {
    const std::string path = uri.substr(file.size());
    if (path.empty() || path.front() != '/') {
      throw std::runtime_error("mesh \"" + uri + "\": a file:// URI needs an absolute path (file:///path)");
    }
    return path;
  }
  if (uri.compare(0, package.size(), package) == 0) {
    const std::string rest = uri.substr(package.size());
    const size_t slash = rest.find('/');
    const std::string name = rest.substr(0, slash);
    if (name.empty() || slash == std::string::npos || slash + 1 == rest.size()) {
      throw std::runtime_error("mesh \"" + uri + "\": a package:// URI is package://<package>/<path>");
    }
    const std::string root = ros::package::getPath(name);
    if (root.empty()) {
      throw std::runtime_error("cannot retrieve mesh \"" + uri + "\": package \"" + name +
                               "\" not found (is it on ROS_PACKAGE_PATH?)");
    }
    return root + rest.substr(slash);
  }
  throw std::runtime_error("mesh \"" + uri +
                           "\": only package:// and file:// URIs are supported (a remote mesh could not be "
                           "bounded to " + limitText() + " before it is read)");
}

std::vector<char> readMeshResource(const std::string& uri) { return readBounded(uri, meshPath(uri)); }

namespace {

MeshData loadMesh(const std::string& uri, const Eigen::Vector3d& scale) {
  const std::vector<char> res = readMeshResource(uri);
  if (res.empty()) throw std::runtime_error("mesh \"" + uri + "\" is empty");
  Assimp::Importer importer;
  const aiScene* scene = importer.ReadFileFromMemory(
      res.data(), res.size(),
      aiProcess_Triangulate | aiProcess_JoinIdenticalVertices | aiProcess_PreTransformVertices |
          aiProcess_SortByPType,
      extensionOf(uri).c_str());
  if (!scene) {
    throw std::runtime_error("cannot read mesh \"" + uri + "\": " + importer.GetErrorString());
  }
  MeshData out;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* mesh = scene->mMeshes[m];
    const int base = static_cast<int>(out.vertices.size());
    for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
      const aiVector3D& p = mesh->mVertices[v];
      out.vertices.emplace_back(p.x * scale.x(), p.y * scale.y(), p.z * scale.z());
    }
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      if (face.mNumIndices != 3) continue;  // points and lines carry no volume
      out.triangles.push_back({base + static_cast<int>(face.mIndices[0]), base + static_cast<int>(face.mIndices[1]),
                               base + static_cast<int>(face.mIndices[2])});
    }
  }
  if (out.triangles.empty()) throw std::runtime_error("mesh \"" + uri + "\" has no triangles");
  return out;
}

}  // namespace

MeshLoader makeDefaultMeshLoader() {
  struct Cache {
    std::mutex mutex;
    std::map<std::tuple<std::string, double, double, double>, MeshData> meshes;
  };
  auto cache = std::make_shared<Cache>();
  return [cache](const std::string& uri, const Eigen::Vector3d& scale) {
    const auto key = std::make_tuple(uri, scale.x(), scale.y(), scale.z());
    {
      std::lock_guard<std::mutex> lock(cache->mutex);
      const auto it = cache->meshes.find(key);
      if (it != cache->meshes.end()) return it->second;
    }
    MeshData data = loadMesh(uri, scale);
    std::lock_guard<std::mutex> lock(cache->mutex);
    cache->meshes.emplace(key, data);
    return data;
  };
}

namespace {

urdf::ModelInterfaceSharedPtr parseModel(const std::string& urdf_xml) {
  urdf::ModelInterfaceSharedPtr model;
  std::string why;
  {
    CaptureErrors capture;
    model = urdf::parseURDF(urdf_xml);
    why = capture.text();
  }
  if (!model) throw UrdfError("the URDF does not parse" + (why.empty() ? std::string() : ": " + why));
  return model;
}

// Walks the tree breadth first from the root, joints at zero: fills out.link_in_root,
// out.adjacent and out.movable_links, and returns the links in that order.
std::vector<urdf::LinkConstSharedPtr> linksFromRoot(const urdf::ModelInterface& model,
                                                    const urdf::LinkConstSharedPtr& root, UrdfShapes& out) {
  out.link_in_root[root->name] = Eigen::Isometry3d::Identity();
  // Each link with whether a movable joint lies between it and the root.
  std::vector<std::pair<urdf::LinkConstSharedPtr, bool>> todo = {{root, false}};
  for (size_t i = 0; i < todo.size(); ++i) {
    const urdf::LinkConstSharedPtr link = todo[i].first;
    const bool movable = todo[i].second;
    if (movable) out.movable_links.push_back(link->name);
    const Eigen::Isometry3d& parent_pose = out.link_in_root[link->name];
    for (const urdf::JointSharedPtr& joint : link->child_joints) {
      const urdf::LinkConstSharedPtr child = model.getLink(joint->child_link_name);
      if (!child) continue;
      const Eigen::Isometry3d origin = toEigen(joint->parent_to_joint_origin_transform);
      out.link_in_root[child->name] = parent_pose * origin;
      out.adjacent.emplace_back(link->name, child->name);
      todo.emplace_back(child, movable || joint->type != urdf::Joint::FIXED);
    }
  }
  std::vector<urdf::LinkConstSharedPtr> links;
  links.reserve(todo.size());
  for (const auto& entry : todo) links.push_back(entry.first);
  return links;
}

// The library's shape of a URDF geometry into g (and a mesh's URI and scale); "" when done,
// else why it cannot be. Throws what the mesh loader or the library throws.
std::string setShape(const urdf::Geometry& geometry, const MeshLoader& load_mesh, LinkGeometry& g) {
  switch (geometry.type) {
    case urdf::Geometry::SPHERE: {
      const auto& s = static_cast<const urdf::Sphere&>(geometry);
      g.shape = vadop::makeSphere(s.radius);
      return "";
    }
    case urdf::Geometry::BOX: {
      const auto& b = static_cast<const urdf::Box&>(geometry);
      g.shape = vadop::makeBox(Eigen::Vector3d(b.dim.x, b.dim.y, b.dim.z));
      return "";
    }
    case urdf::Geometry::CYLINDER: {
      const auto& cy = static_cast<const urdf::Cylinder&>(geometry);
      g.shape = vadop::makeCylinder(cy.radius, cy.length);
      return "";
    }
    case urdf::Geometry::MESH: {
      const auto& m = static_cast<const urdf::Mesh&>(geometry);
      g.mesh_uri = m.filename;
      g.mesh_scale = Eigen::Vector3d(m.scale.x, m.scale.y, m.scale.z);
      if (!g.mesh_scale.allFinite() || !(g.mesh_scale.minCoeff() > 0.0)) {
        return "mesh \"" + m.filename + "\": the scale must be finite and > 0";
      }
      MeshData data = load_mesh(m.filename, g.mesh_scale);
      g.shape = vadop::makeMesh(std::move(data.vertices), std::move(data.triangles));
      return "";
    }
    default:
      return "unsupported geometry type";
  }
}

// One collision element of a link into out.geometries, or the reason it is left out into
// out.errors.
void addCollision(const urdf::Link& link, size_t k, const urdf::CollisionSharedPtr& c, const MeshLoader& load_mesh,
                  UrdfShapes& out) {
  const std::string where = "link \"" + link.name + "\" collision " + std::to_string(k);
  if (!c || !c->geometry) {
    out.errors.push_back(where + ": no geometry");
    return;
  }
  LinkGeometry g;
  g.link = link.name;
  g.index = static_cast<int>(k);
  g.origin = toEigen(c->origin);
  if (!finitePose(g.origin)) {
    out.errors.push_back(where + ": the origin is not finite");
    return;
  }
  try {
    const std::string why = setShape(*c->geometry, load_mesh, g);
    if (!why.empty()) {
      out.errors.push_back(where + ": " + why);
      return;
    }
  } catch (const vadop::InvalidArgument& e) {
    out.errors.push_back(where + ": invalid geometry: " + e.what());
    return;
  } catch (const std::exception& e) {
    out.errors.push_back(where + ": " + e.what());
    return;
  }
  out.geometries.push_back(std::move(g));
}

}  // namespace

UrdfShapes urdfToShapes(const std::string& urdf_xml, const MeshLoader& load_mesh) {
  const urdf::ModelInterfaceSharedPtr model = parseModel(urdf_xml);
  const urdf::LinkConstSharedPtr root = model->getRoot();
  if (!root) throw UrdfError("the URDF has no root link");

  UrdfShapes out;
  out.robot_name = model->getName();
  out.root_link = root->name;
  for (const urdf::LinkConstSharedPtr& link : linksFromRoot(*model, root, out)) {
    std::vector<urdf::CollisionSharedPtr> collisions = link->collision_array;
    if (collisions.empty() && link->collision) collisions.push_back(link->collision);
    for (size_t k = 0; k < collisions.size(); ++k) addCollision(*link, k, collisions[k], load_mesh, out);
  }
  return out;
}

}  // namespace vadop_ros
