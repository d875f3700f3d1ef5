// vadop_core (vadop/world.h, libvadop_core) from a dependent package; see predict.h.
#include "predict.h"

#include <vadop/world.h>

std::vector<PlainImpact> predictHeadOn() {
  vadop::World world;
  const auto moving = [](double x, double vx) {
    return vadop::makeMotion(Eigen::Vector3d(x, 0, 0), Eigen::Quaterniond::Identity(),
                             Eigen::Vector3d(vx, 0, 0), Eigen::Vector3d::Zero(), 0.0);
  };
  world.add("left", vadop::makeSphere(0.5), moving(0.0, 1.0));
  world.add("right", vadop::makeSphere(0.25), moving(4.0, -2.0));
  std::vector<PlainImpact> out;
  for (const vadop::Contact& w : world.predict(0.0, 2.0)) {
    PlainImpact p;
    p.a = w.a;
    p.b = w.b;
    p.time = w.impact.time;
    for (int i = 0; i < 3; ++i) {
      p.point[i] = w.impact.point[i];
      p.normal[i] = w.impact.normal[i];
    }
    p.initially_touching = w.impact.initially_touching;
    out.push_back(p);
  }
  return out;
}
