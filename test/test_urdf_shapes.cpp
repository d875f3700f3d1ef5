// URDF -> shapes: every collision element with its origin and scale; errors name the link.
#include "vadop_ros/urdf_shapes.h"
#include "yaml_xmlrpc.h"

#include <gtest/gtest.h>

#include <stdlib.h>

#include <chrono>
#include <cstdlib>

using vadop_ros::LinkGeometry;
using vadop_ros::UrdfError;
using vadop_ros::UrdfShapes;
using vadop_ros::urdfToShapes;

namespace {

std::string testUrdf() {
  std::string text = vadop_test::readFile(VADOP_TEST_DATA_DIR "/two_link.urdf");
  const std::string key = "@DATA_DIR@";
  for (size_t p = text.find(key); p != std::string::npos; p = text.find(key)) text.replace(p, key.size(), VADOP_TEST_DATA_DIR);
  return text;
}

const LinkGeometry* find(const UrdfShapes& s, const std::string& link, int index = 0) {
  for (const auto& g : s.geometries) {
    if (g.link == link && g.index == index) return &g;
  }
  return nullptr;
}

bool contains(const std::vector<std::string>& v, const std::string& part) {
  for (const auto& s : v) {
    if (s.find(part) != std::string::npos) return true;
  }
  return false;
}

}  // namespace

TEST(UrdfShapes, EveryCollisionElement) {
  const UrdfShapes s = urdfToShapes(testUrdf(), vadop_ros::makeDefaultMeshLoader());
  EXPECT_EQ(s.robot_name, "testbot");
  EXPECT_EQ(s.root_link, "base_link");

  const LinkGeometry* box = find(s, "base_link", 0);
  ASSERT_NE(box, nullptr);
  EXPECT_EQ(box->shape.type, vadop::ShapeType::kBox);
  EXPECT_TRUE(box->shape.half_extents.isApprox(Eigen::Vector3d(0.2, 0.1, 0.1)));
  EXPECT_TRUE(box->origin.translation().isApprox(Eigen::Vector3d(0, 0, 0.1)));

  const LinkGeometry* cyl = find(s, "base_link", 1);
  ASSERT_NE(cyl, nullptr);
  EXPECT_EQ(cyl->shape.type, vadop::ShapeType::kCylinder);
  EXPECT_DOUBLE_EQ(cyl->shape.radius, 0.1);
  EXPECT_DOUBLE_EQ(cyl->shape.half_length, 0.1);
  EXPECT_NEAR(cyl->origin.translation().z(), 0.3, 1e-12);

  const LinkGeometry* sphere = find(s, "mast");
  ASSERT_NE(sphere, nullptr);
  EXPECT_EQ(sphere->shape.type, vadop::ShapeType::kSphere);
  EXPECT_DOUBLE_EQ(sphere->shape.radius, 0.05);

  const LinkGeometry* mesh = find(s, "arm");
  ASSERT_NE(mesh, nullptr);
  EXPECT_EQ(mesh->shape.type, vadop::ShapeType::kMesh);
  EXPECT_EQ(mesh->shape.triangles.size(), 12u);
  EXPECT_TRUE(mesh->mesh_scale.isApprox(Eigen::Vector3d(2, 1, 1)));
  // The scale is applied to the vertices: x spans [-1, 1].
  double max_x = 0;
  for (const auto& v : mesh->shape.points) max_x = std::max(max_x, v.x());
  EXPECT_NEAR(max_x, 1.0, 1e-9);
  EXPECT_NEAR(vadop::support(mesh->shape, Eigen::Vector3d::UnitX()), 1.0, 1e-9);
  EXPECT_NEAR(vadop::support(mesh->shape, Eigen::Vector3d::UnitY()), 0.5, 1e-9);

  // No geometry for the link without <collision>; the unloadable mesh is an error naming its link.
  EXPECT_EQ(find(s, "sensor"), nullptr);
  EXPECT_EQ(find(s, "broken"), nullptr);
  ASSERT_TRUE(contains(s.errors, "link \"broken\" collision 0"));
  EXPECT_TRUE(contains(s.errors, "missing.stl"));
}

TEST(UrdfShapes, PackageUri) {
  if (!std::getenv("ROS_PACKAGE_PATH")) GTEST_SKIP() << "ROS_PACKAGE_PATH not set (source devel/setup.bash)";
  const UrdfShapes s = urdfToShapes(testUrdf(), vadop_ros::makeDefaultMeshLoader());
  const LinkGeometry* mesh = find(s, "pkg_mesh");
  ASSERT_NE(mesh, nullptr) << (s.errors.empty() ? "" : s.errors.front());
  EXPECT_NEAR(vadop::support(mesh->shape, Eigen::Vector3d::UnitZ()), 0.25, 1e-9);
}

TEST(UrdfShapes, LinkPosesWithJointsAtZero) {
  const UrdfShapes s = urdfToShapes(testUrdf(), vadop_ros::makeDefaultMeshLoader());
  ASSERT_TRUE(s.link_in_root.count("mast"));
  EXPECT_TRUE(s.link_in_root.at("mast").translation().isApprox(Eigen::Vector3d(0, 0, 0.4)));
  // sensor: through two fixed joints.
  EXPECT_TRUE(s.link_in_root.at("sensor").translation().isApprox(Eigen::Vector3d(0, 0, 1.4)));
  // arm: revolute at zero -> the joint origin, rotated 90 degrees about z.
  const Eigen::Isometry3d arm = s.link_in_root.at("arm");
  EXPECT_TRUE(arm.translation().isApprox(Eigen::Vector3d(0.2, 0, 0.3)));
  EXPECT_TRUE((arm.linear() * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d::UnitY(), 1e-9));
  EXPECT_EQ(s.movable_links, std::vector<std::string>{"arm"});
  // Adjacent (joined) links.
  bool base_mast = false;
  for (const auto& pc : s.adjacent) base_mast |= pc.first == "base_link" && pc.second == "mast";
  EXPECT_TRUE(base_mast);
}

TEST(UrdfShapes, MalformedUrdfThrows) {
  const auto loader = vadop_ros::makeDefaultMeshLoader();
  EXPECT_THROW(urdfToShapes("<robot name='x'><link name='a'>", loader), UrdfError);
  EXPECT_THROW(urdfToShapes("not xml at all", loader), UrdfError);
  // A joint to a link that does not exist.
  EXPECT_THROW(urdfToShapes("<robot name='x'><link name='a'/><joint name='j' type='fixed'><parent link='a'/>"
                            "<child link='b'/></joint></robot>",
                            loader),
               UrdfError);
  try {
    urdfToShapes("<robot name='x'><link name='a'>", loader);
  } catch (const UrdfError& e) {
    EXPECT_NE(std::string(e.what()).find("does not parse"), std::string::npos);
  }
}

TEST(UrdfShapes, InvalidGeometryIsAnErrorNamingTheLink) {
  const auto loader = vadop_ros::makeDefaultMeshLoader();
  const UrdfShapes s = urdfToShapes(
      "<robot name='x'><link name='a'><collision><geometry><sphere radius='0.5'/></geometry></collision></link>"
      "<link name='bad'><collision><geometry><box size='1 0 1'/></geometry></collision></link>"
      "<joint name='j' type='fixed'><parent link='a'/><child link='bad'/></joint></robot>",
      loader);
  ASSERT_EQ(s.geometries.size(), 1u);
  EXPECT_EQ(s.geometries[0].link, "a");
  ASSERT_EQ(s.errors.size(), 1u);
  EXPECT_NE(s.errors[0].find("link \"bad\""), std::string::npos);
}

TEST(UrdfShapes, MeshLoaderCachesAndReportsErrors) {
  int calls = 0;
  vadop_ros::MeshLoader counting = [&calls](const std::string& uri, const Eigen::Vector3d&) -> vadop_ros::MeshData {
    ++calls;
    throw std::runtime_error("no such mesh " + uri);
  };
  const UrdfShapes s = urdfToShapes(
      "<robot name='x'><link name='a'><collision><geometry><mesh filename='package://nope/m.stl'/></geometry>"
      "</collision></link></robot>",
      counting);
  EXPECT_EQ(calls, 1);
  EXPECT_TRUE(s.geometries.empty());
  ASSERT_EQ(s.errors.size(), 1u);
  EXPECT_NE(s.errors[0].find("link \"a\" collision 0: no such mesh package://nope/m.stl"), std::string::npos);
}

// Issue 13, item 9: mesh reads are bounded. file:///dev/zero and a 2 GB (sparse) file used to be
// read until allocation failed (~1 GB, 10-13 s); both are refused before a byte is read, with
// the per-link error naming the URI (and the limit).
namespace {

// A temporary directory, removed with everything in it when the test ends.
struct TempDir {
  std::string path;
  TempDir() {
    char tmpl[] = "/tmp/vadop_test_urdf_XXXXXX";
    const char* p = ::mkdtemp(tmpl);
    if (p) path = p;
  }
  ~TempDir() {
    if (!path.empty()) std::system(("rm -rf '" + path + "'").c_str());
  }
};

std::string meshUrdf(const std::string& uri) {
  return "<robot name='x'><link name='a'><collision><geometry><sphere radius='0.5'/></geometry></collision></link>"
         "<link name='m'><collision><geometry><mesh filename='" +
         uri +
         "'/></geometry></collision></link>"
         "<joint name='j' type='fixed'><parent link='a'/><child link='m'/></joint></robot>";
}

// The error urdfToShapes reports for link "m" (its mesh), and how long the conversion took.
std::string meshError(const std::string& uri, double& seconds) {
  const auto start = std::chrono::steady_clock::now();
  const UrdfShapes s = urdfToShapes(meshUrdf(uri), vadop_ros::makeDefaultMeshLoader());
  seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(s.geometries.size(), 1u);  // link "a" is still there
  if (s.errors.size() != 1u) {
    ADD_FAILURE() << "errors: " << s.errors.size();
    return "";
  }
  return s.errors[0];
}

}  // namespace

TEST(UrdfShapes, MeshFromADeviceIsRefusedBeforeReading) {
  double seconds = 0;
  const std::string e = meshError("file:///dev/zero", seconds);
  EXPECT_NE(e.find("link \"m\" collision 0: mesh \"file:///dev/zero\": /dev/zero is not a regular file"), std::string::npos)
      << e;
  EXPECT_LT(seconds, 1.0);  // before: ~1 GB read, 10-13 s (a bound of 1 s, not a benchmark)
  EXPECT_NE(meshError("file:///tmp", seconds).find("/tmp is not a regular file"), std::string::npos);
}

TEST(UrdfShapes, MeshLargerThanTheLimitIsRefusedBeforeReading) {
  TempDir dir;
  ASSERT_FALSE(dir.path.empty());
  const std::string big = dir.path + "/big.stl";
  // A sparse 2 GiB file: no disk space used.
  ASSERT_EQ(std::system(("truncate -s 2G '" + big + "'").c_str()), 0);
  double seconds = 0;
  const std::string e = meshError("file://" + big, seconds);
  EXPECT_NE(e.find("mesh \"file://" + big + "\" is 2147483648 bytes, more than the limit of 64 MiB (kMaxMeshBytes)"),
            std::string::npos)
      << e;
  EXPECT_LT(seconds, 1.0);
  // Just above the limit: refused; at the limit: read (and then not a valid STL).
  const std::string edge = dir.path + "/edge.stl";
  ASSERT_EQ(std::system(("truncate -s " + std::to_string(vadop_ros::kMaxMeshBytes + 1) + " '" + edge + "'").c_str()), 0);
  EXPECT_THROW(vadop_ros::readMeshResource("file://" + edge), std::runtime_error);
  ASSERT_EQ(std::system(("truncate -s " + std::to_string(vadop_ros::kMaxMeshBytes) + " '" + edge + "'").c_str()), 0);
  EXPECT_EQ(vadop_ros::readMeshResource("file://" + edge).size(), vadop_ros::kMaxMeshBytes);
}

TEST(UrdfShapes, MeshUriSchemes) {
  // file:// and package:// resolve to paths; every other scheme is refused with a clear message.
  EXPECT_EQ(vadop_ros::meshPath("file:///a/b.stl"), "/a/b.stl");
  for (const std::string uri : {"http://example.com/m.stl", "https://example.com/m.stl", "/abs/m.stl", "m.stl",
                                "ftp://h/m.stl"}) {
    try {
      vadop_ros::meshPath(uri);
      ADD_FAILURE() << uri;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("mesh \"" + uri + "\": only package:// and file:// URIs are supported"),
                std::string::npos)
          << e.what();
    }
  }
  EXPECT_THROW(vadop_ros::meshPath("file://relative/m.stl"), std::runtime_error);
  EXPECT_THROW(vadop_ros::meshPath("package://"), std::runtime_error);
  EXPECT_THROW(vadop_ros::meshPath("package://vadop"), std::runtime_error);
  try {
    vadop_ros::meshPath("package://no_such_package_vadop/m.stl");
    ADD_FAILURE();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("package \"no_such_package_vadop\" not found"), std::string::npos) << e.what();
  }
  if (std::getenv("ROS_PACKAGE_PATH")) {
    const std::string p = vadop_ros::meshPath("package://vadop/test/data/cube.stl");
    EXPECT_EQ(p.substr(p.size() - std::string("/test/data/cube.stl").size()), "/test/data/cube.stl");
  }
  double seconds = 0;
  EXPECT_NE(meshError("file:///no/such/file.stl", seconds).find("cannot retrieve mesh \"file:///no/such/file.stl\""),
            std::string::npos);
}
