// A roscpp callback queue that runs each callback at once, on the thread that adds it: for a
// subscription, roscpp's receiving thread (or, intraprocess, the publisher's), as the message
// arrives. It suits callbacks that take no lock a cycle may hold and return in microseconds
// (the odometry callbacks posting into their body's slot, pose_twist_source.h): at 30,000
// messages a second a queue served by a spinner woke that thread once per message, which cost
// more CPU than the rest of the message's handling.
// It does not queue, order or drop: a subscription's own queue (queue_size) is never more than
// one deep. Unsubscribing waits for a running callback (roscpp holds the subscription's lock
// around it), so the callbacks' objects may be destroyed after their subscriptions.
#pragma once

#include <ros/callback_queue_interface.h>

#include <cstdint>
#include <thread>

namespace vadop_ros {

class ReceivingThreadQueue : public ros::CallbackQueueInterface {
 public:
  void addCallback(const ros::CallbackInterfacePtr& callback, uint64_t /*owner_id*/) override {
    // TryAgain: the same subscription's callback is running on another thread (an intraprocess
    // publisher beside the receiving thread); it is short, so wait for it rather than lose
    // the message.
    while (callback->call() == ros::CallbackInterface::TryAgain) std::this_thread::yield();
  }
  void removeByID(uint64_t /*owner_id*/) override {}
};

}  // namespace vadop_ros
