// A first program with vadop_core: a robot drives at 1 m/s towards a crate while a person walks
// across its path. What touches first, when, where? And if the robot stopped now? Prints the
// answers; exits 1 unless they are the ones computed by hand below.
#include <vadop/world.h>

#include <cmath>
#include <cstdio>

int main() {
  const Eigen::Quaterniond upright = Eigen::Quaterniond::Identity();
  vadop::World world;
  // A body: an id, a shape about its origin (URDF conventions: a cylinder's axis is z) and a
  // motion: the pose at t_ref = 0 and a constant twist (m/s, rad/s, in the fixed frame).
  world.add("robot", vadop::makeCylinder(0.3, 0.5), vadop::makeMotion({0, 0, 0.25}, upright, {1, 0, 0}, {0, 0, 0}));
  world.add("crate", vadop::makeBox({0.6, 0.6, 0.6}), vadop::makeMotion({2.5, 0, 0.3}, upright, {0, 0, 0}, {0, 0, 0}));
  world.add("person", vadop::makeCylinder(0.25, 1.8), vadop::makeMotion({1, 3, 0.9}, upright, {0, -2, 0}, {0, 0, 0}));

  // Every pair that touches within [0, 2 s], soonest first.
  const std::vector<vadop::Contact> contacts = world.predict(0.0, 2.0);
  for (const vadop::Contact& c : contacts) {
    std::printf("%s touches %s in %.4f s at (%.3f, %.3f, %.3f), normal (%.3f, %.3f, %.3f), closing at %.2f m/s\n",
                c.a.c_str(), c.b.c_str(), c.impact.time, c.impact.point.x(), c.impact.point.y(), c.impact.point.z(),
                c.impact.normal.x(), c.impact.normal.y(), c.impact.normal.z(), c.closing_speed);
  }
  // A velocity gate's question: what would the robot touch if it stopped now? (The world stays.)
  const auto stopped = world.firstContactIf({"robot"}, {vadop::makeMotion({0, 0, 0.25}, upright, {0, 0, 0}, {0, 0, 0})},
                                            0.0, 2.0);
  std::printf("if the robot stops: %s\n", stopped ? ("touches " + stopped->other).c_str() : "nothing within 2 s");

  // By hand: the centres (t, 0) and (1, 3 - 2t) are 0.3 + 0.25 apart when 5t^2 - 14t + 9.6975 = 0,
  // t = (14 - sqrt(2.05)) / 10; the robot's front (0.3 + t) reaches the crate's face (2.2) at 1.9 s;
  // standing still, the person passes 1 m away.
  const double t_person = (14.0 - std::sqrt(2.05)) / 10.0;
  const bool ok = contacts.size() == 2 && contacts[0].b == "person" && std::abs(contacts[0].impact.time - t_person) < 1e-6 &&
                  contacts[1].b == "crate" && std::abs(contacts[1].impact.time - 1.9) < 1e-6 && !stopped;
  std::printf("%s\n", ok ? "as computed by hand" : "NOT as computed by hand");
  return ok ? 0 : 1;
}
