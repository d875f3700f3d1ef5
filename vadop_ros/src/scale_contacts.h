// What a velocity gate's scale search met (vadop::searchGateScale over the command scaled by
// s): the first contact found at each scale tried, kept to name what limits the chosen scale
// afterwards. It does not search (CommandedSweep, GateManoeuvre do) nor judge a contact.
#pragma once

#include <vadop/world.h>

#include <limits>
#include <optional>
#include <utility>
#include <vector>

namespace vadop_ros {

class ScaleContacts {
 public:
  // Keeps scale s's contact; the time to hand searchGateScale (+inf when clear).
  double note(double s, std::optional<vadop::World::MoverContact> contact) {
    if (!contact) return std::numeric_limits<double>::infinity();
    seen_.push_back({s, std::move(*contact)});
    return seen_.back().contact.impact.time;
  }

  // The contact that limits `scale`: when clear, that of the smallest blocked scale (just
  // above it); else the chosen scale's own. Null when nothing limits it.
  const vadop::World::MoverContact* limit(const vadop::GateScale& scale) const {
    const Seen* found = nullptr;
    for (const Seen& x : seen_) {
      if (scale.clear ? (!found || x.s < found->s) : x.s == scale.scale) found = &x;
    }
    return found ? &found->contact : nullptr;
  }

 private:
  struct Seen {
    double s;
    vadop::World::MoverContact contact;  // mover: a position in the search's movers
  };
  std::vector<Seen> seen_;
};

}  // namespace vadop_ros
