// A dependent of vadop (test/downstream/check.sh): vadop_core's World predicts a head-on pair
// (predict.cpp) and the result goes into vadop's ImpactArray message. Exit 0 when it is right.
#include "predict.h"

#include <vadop/ImpactArray.h>  // generated message of the vadop package
#include <vadop/world.h>        // and the library, in the same translation unit

#include <cmath>
#include <cstdio>

int main() {
  vadop::ImpactArray msg;
  msg.header.frame_id = "odom";
  for (const PlainImpact& p : predictHeadOn()) {
    vadop::Impact impact;
    impact.body_a = p.a;
    impact.body_b = p.b;
    impact.time_to_impact = p.time;
    impact.point.x = p.point[0];
    impact.point.y = p.point[1];
    impact.point.z = p.point[2];
    impact.normal.x = p.normal[0];
    impact.normal.y = p.normal[1];
    impact.normal.z = p.normal[2];
    impact.in_contact = p.initially_touching;
    msg.impacts.push_back(impact);
  }

  // Gap 4 - 0.75 = 3.25 closing at 3 m/s: contact at 13/12 s (reported up to the narrow
  // phase's tolerance earlier), normal +x from left to right.
  const bool ok = msg.impacts.size() == 1 && msg.impacts[0].body_a == "left" &&
                  msg.impacts[0].body_b == "right" &&
                  std::abs(msg.impacts[0].time_to_impact - 13.0 / 12.0) < 1e-3 &&
                  std::abs(msg.impacts[0].normal.x - 1.0) < 1e-9 && !msg.impacts[0].in_contact;
  if (ok) {
    std::printf("vadop_downstream_check: %s-%s at %.6f s: ok\n", msg.impacts[0].body_a.c_str(),
                msg.impacts[0].body_b.c_str(), msg.impacts[0].time_to_impact);
    return 0;
  }
  std::printf("vadop_downstream_check: wrong result (%zu impacts)\n", msg.impacts.size());
  return 1;
}
