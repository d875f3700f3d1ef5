// URDF -> shapes: every collision element with its origin and scale; errors name the link.
#include "vadop_ros/urdf_shapes.h"
#include "yaml_xmlrpc.h"

#include <gtest/gtest.h>

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
