#!/usr/bin/python3
"""rostest node of test/tutorials/people.test: what docs/tutorials/people.md promises. The robot
(cylinder, radius 0.3 m) drives +x at 1 m/s from the origin; a tracker reports person "7" (type 0:
the source's default cylinder, radius 0.3 m) walking +y at 1 m/s from (3, -2.5), centred at
z = 0.9 m. Every impact must be robot <-> people/7 at the analytic time within 50 ms until the
tracker stops reporting the person; after the source's timeout (0.5 s) no impact names them."""
import math
import sys
import unittest

import rospy
import rostest
from nav_msgs.msg import Odometry
from vadop.msg import TrackedObjectArray

import tutorial_sim

RADIUS = 0.3          # both cylinders
PERSON_START = (3.0, -2.5)
PERSON_Z = 0.9
ODOM_HZ = 50.0
TRACK_HZ = 15.0
TRACKS_STOP = 2.0     # s after the start: the tracker loses the person (before the contact)
RUN_SECONDS = 3.2     # the robot drives on alone
TIMEOUT = 0.5         # config/tutorials/people.yaml


def contact_time():
    """First t with |person(t) - robot(t)| = 2 RADIUS: (3 - t)^2 + (t - 2.5)^2 = 0.36."""
    px, py = PERSON_START
    # relative position (px - t, py + t): 2 t^2 - 2 (px - py) t + px^2 + py^2 - (2 RADIUS)^2 = 0
    a, b, c = 2.0, -2.0 * (px - py), px * px + py * py - (2 * RADIUS) ** 2
    return (-b - math.sqrt(b * b - 4 * a * c)) / (2 * a)


class People(unittest.TestCase):
    def test_robot_and_person(self):
        rospy.init_node("people_check")
        odom = rospy.Publisher("/robot/odom", Odometry, queue_size=10)
        tracks = rospy.Publisher("/people/tracks", TrackedObjectArray, queue_size=10)
        impacts = tutorial_sim.ImpactRecorder()
        self.assertTrue(tutorial_sim.wait_for_connections([odom, tracks], [impacts.sub]),
                        "vadop_monitor did not connect")
        rospy.sleep(0.5)
        start = rospy.Time.now()
        rate = rospy.Rate(ODOM_HZ)
        next_track = 0.0
        while not rospy.is_shutdown():
            now = rospy.Time.now()
            t = (now - start).to_sec()
            if t > RUN_SECONDS:
                break
            odom.publish(tutorial_sim.odometry(now, "robot", t, 0.0, 0.0, 1.0, 0.0))
            if t >= next_track and t < TRACKS_STOP:
                array = TrackedObjectArray()
                array.header.stamp = now
                array.header.frame_id = "odom"
                person = tutorial_sim.tracked_object("7", PERSON_START[0], PERSON_START[1] + t, 0.0, 1.0)
                person.pose.position.z = PERSON_Z
                array.objects.append(person)
                tracks.publish(array)
                next_track = t + 1.0 / TRACK_HZ
            rate.sleep()
        rospy.sleep(0.1)

        contact = start + rospy.Duration(contact_time())
        seen = impacts.since(start + rospy.Duration(0.2))
        tracked = [a for a in seen if a.header.stamp < start + rospy.Duration(TRACKS_STOP)]
        for a in tracked:
            for i in a.impacts:
                if {i.body_a, i.body_b} != {"robot", "people/7"}:
                    self.fail("unexpected pair %s" % i)
        found = tutorial_sim.impacts_of_pair(tracked, "robot", "people/7")
        self.assertGreater(len(found), len(tracked) // 2, "robot <-> people/7 in %d of %d arrays" %
                           (len(found), len(tracked)))
        worst = max(abs(e) for e in tutorial_sim.timing_errors(found, contact))
        rospy.loginfo("people: robot <-> people/7 at %.4f s after the start, %d reports, largest error %.2f ms",
                      contact_time(), len(found), 1e3 * worst)
        self.assertLess(worst, 0.05)

        gone = [a for a in seen if a.header.stamp > start + rospy.Duration(TRACKS_STOP + TIMEOUT + 0.2)]
        self.assertGreater(len(gone), 10)
        for a in gone:
            if any("people/7" in (i.body_a, i.body_b) for i in a.impacts):
                self.fail("people/7 still predicted %.2f s after the start, its last array at %.1f s" %
                          ((a.header.stamp - start).to_sec(), TRACKS_STOP))


if __name__ == "__main__":
    rostest.rosrun("vadop", "tutorial_people", People, sys.argv)
