// One body's mailbox between its transport callback and the cycle (PoseTwistSource): the
// latest accepted velocity state, the stamp the stamp policy orders against, and what happened
// to the messages since the cycle last took it (accepted, dropped as invalid with the last
// reason, ignored as out of order).
//
// Why: at 1,000 odometry topics at 30 Hz a callback that took the node's one lock per message
// waited behind the cycle and woke a spinner thread per message; with this slot the callback
// writes the body's state under the slot's own mutex, which only this body's callback and the
// cycle ever take, each for a copy of a few hundred bytes.
//
// Ownership (the only data the callback thread and the cycle share):
//  - written by the callback (PoseTwistSource::post), under `mutex`: everything below;
//  - read and cleared by the cycle (PoseTwistSource::collect, under the node's lock and
//    `mutex`): `state` (swapped out whole), the pending counts, the last drop;
//  - `last_stamp` and `has_state` belong to the stamp policy: the callback reads and writes
//    them, reset() clears them (under `mutex`);
//  - `pending` says, without the mutex, whether there is anything to collect: set (release)
//    after a write, cleared under the mutex by the collector, so a cycle over 10,000 quiet
//    bodies takes no mutex. A set flag is always followed by a collect that sees the write.
// It does not: check the message (the source does before posting), warn (the cycle does, from
// the pending drop, through the registry's throttle) or touch the Body.
#pragma once

#include "vadop_ros/source.h"

#include <ros/time.h>

#include <atomic>
#include <cstdint>
#include <mutex>
#include <string>

namespace vadop_ros {

struct StateSlot {
  std::mutex mutex;
  std::atomic<bool> pending{false};
  VelocityState state;  // the latest accepted state (valid while accepted > 0)
  ros::Time last_stamp;  // of the last accepted state, for the stamp policy
  bool has_state = false;
  ros::Time last_receipt;  // of the last accepted state
  uint64_t accepted = 0, invalid = 0, out_of_order = 0;  // since the last collect
  std::string last_invalid;  // why the last invalid message was dropped
  ros::Time last_invalid_receipt;
};

}  // namespace vadop_ros
