#!/usr/bin/python3
"""Four region monitors against one over the whole fleet, in real processes (test/sharded.test).

The fleet driver runs its own simulated clock (~clock_step): it publishes a state of the fleet
stamped t, then, half a wall period later, /clock t + step, so that every monitor's cycle at
t + step predicts from that same state at that same time (their timers follow /clock; nothing is
published until the next state). An ImpactArray stamped t + step therefore comes from the state
stamped t, in every monitor; per such stamp, with every monitor's array:
  - the union of the four region monitors' impacts equals the whole monitor's, as sets of
    (body, link, other body, other link) pairs, each with the same time to impact within 1 ms;
  - a region monitor reports only pairs with a body inside its ~region (read from the
    parameter server) at the cycle: the state's pose moved on along its heading for one step,
    within 5 cm (the arc's bend over a step is under 1 cm);
  - enough was compared: >= ~min_states states, >= ~min_pairs impacts, >= ~min_across pairs
    whose bodies lie in different regions (the borders are crossed).
The first ~skip states are left out: a process still starting up may read the clock's message
before the state's, half a wall period older.
Private parameters: regions (the four monitors' names), whole (the whole fleet's monitor),
states_topic (/fleet/states), step (the driver's ~clock_step), skip (3), min_states,
min_pairs, min_across, timeout (wall seconds to collect them).
"""
import math
import threading
import time
import unittest

import rospy
import rostest
from vadop.msg import BodyStateArray, ImpactArray

INSIDE_TOLERANCE = 0.05  # m
TIME_TOLERANCE = 1e-3  # s


def pair_key(impact):
    return tuple(sorted([(impact.body_a, impact.link_a), (impact.body_b, impact.link_b)]))


def inside(box, p, grow=0.0):
    return all(box["min"][k] - grow <= p[k] <= box["max"][k] + grow for k in range(2))


class Collector:
    """The states by stamp and each monitor's ImpactArray by stamp (nanoseconds)."""

    def __init__(self, monitors, states_topic, skip):
        self.lock = threading.Lock()
        self.states = {}  # stamp -> {name: (x, y, x at the next step, y at the next step)}
        self.arrays = {m: {} for m in monitors}  # monitor -> stamp -> {pair: time to impact}
        self.step = rospy.get_param("~step")
        self.skip = skip
        self.subs = [rospy.Subscriber(states_topic, BodyStateArray, self.on_states, queue_size=10)]
        for m in monitors:
            self.subs.append(rospy.Subscriber(m + "/impacts", ImpactArray, self.on_impacts, m, queue_size=50))

    def on_states(self, msg):
        places = {}
        for s in msg.states:
            q = s.pose.orientation
            yaw = 2.0 * math.atan2(q.z, q.w)
            moved = s.twist.linear.x * self.step
            x, y = s.pose.position.x, s.pose.position.y
            places[s.name] = (x, y, x + moved * math.cos(yaw), y + moved * math.sin(yaw))
        with self.lock:
            self.states[msg.header.stamp.to_nsec()] = places

    def on_impacts(self, msg, monitor):
        pairs = {pair_key(i): i.time_to_impact for i in msg.impacts}
        with self.lock:
            self.arrays[monitor][msg.header.stamp.to_nsec()] = pairs

    def complete(self):
        """Cycle stamps with every monitor's array and their state, the driver since moved on."""
        step_ns = int(round(self.step * 1e9))
        with self.lock:
            if not self.states:
                return []
            first = min(self.states) + self.skip * step_ns
            stamps = set.intersection(*[set(a) for a in self.arrays.values()])
            return sorted(t for t in stamps if t - step_ns in self.states and first <= t - step_ns and max(self.states) >= t)


class ShardedMonitors(unittest.TestCase):
    def test_union_of_regions_is_the_whole(self):
        rospy.init_node("sharded_test")
        regions = rospy.get_param("~regions")
        whole = rospy.get_param("~whole")
        boxes = {m: rospy.get_param(m + "/region") for m in regions}
        collector = Collector(regions + [whole], rospy.get_param("~states_topic", "/fleet/states"),
                              rospy.get_param("~skip", 3))
        min_states = rospy.get_param("~min_states", 15)
        deadline = time.time() + rospy.get_param("~timeout", 40.0)
        while len(collector.complete()) < min_states and time.time() < deadline and not rospy.is_shutdown():
            time.sleep(0.1)  # wall time: the ROS clock is the driver's
        stamps = collector.complete()
        self.assertGreaterEqual(len(stamps), min_states,
                                "states with every monitor's ImpactArray: %d; arrays per monitor: %s" %
                                (len(stamps), {m: len(a) for m, a in collector.arrays.items()}))
        step_ns = int(round(collector.step * 1e9))
        problems, pairs, across = [], 0, 0
        for t in stamps:
            places = collector.states[t - step_ns]
            at_cycle = {name: (p[2], p[3]) for name, p in places.items()}
            truth = collector.arrays[whole][t]
            united = {}
            for m in regions:
                for key, tti in collector.arrays[m][t].items():
                    if not any(inside(boxes[m], at_cycle[body], INSIDE_TOLERANCE) for body, _ in key):
                        problems.append("%s: %s reported by %s, neither body inside its region" % (t, key, m))
                    if key not in truth:
                        problems.append("%s: %s reported by %s only (at %.4f s)" % (t, key, m, tti))
                    elif abs(tti - truth[key]) > TIME_TOLERANCE:
                        problems.append("%s: %s at %.4f s by %s, %.4f s by the whole" % (t, key, tti, m, truth[key]))
                    united[key] = tti
            for key, tti in truth.items():
                if key not in united:
                    problems.append("%s: %s at %.4f s lost at a border" % (t, key, tti))
                region_of = [[m for m in regions if inside(boxes[m], at_cycle[body])] for body, _ in key]
                across += 1 if region_of[0] != region_of[1] else 0
            pairs += len(truth)
        text = "%d states, %d impacts, %d across regions; %d problem(s):\n  %s" % (
            len(stamps), pairs, across, len(problems), "\n  ".join(problems[:20]))
        rospy.loginfo("sharded: %s", text)
        self.assertEqual(len(problems), 0, text)
        self.assertGreaterEqual(pairs, rospy.get_param("~min_pairs", 30), text)
        self.assertGreaterEqual(across, rospy.get_param("~min_across", 3), text)


if __name__ == "__main__":
    rostest.rosrun("vadop", "sharded", ShardedMonitors)
