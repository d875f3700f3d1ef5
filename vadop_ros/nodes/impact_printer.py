#!/usr/bin/python3
"""Prints vadop_monitor's predicted impacts as readable lines (the headless demo's output).

Subscribes to ~impacts_topic (default /vadop_monitor/impacts, vadop/ImpactArray) and, at most once
per ~period seconds (1.0), prints the latest array:

  [t=12.4 s] 3 predicted impacts:
    agent_0/base_link <-> agent_1/base_link   in 0.83 s at (0.12, 4.00, 0.15), closing at 1.60 m/s
    agent_5/mast      <-> wall_east           in contact now

Private parameters: impacts_topic, period (s, 1.0), max_lines (10).
"""
import rospy
from vadop.msg import ImpactArray


def label(body, link):
    return "%s/%s" % (body, link) if link else body


class Printer:
    def __init__(self):
        self.period = rospy.Duration(float(rospy.get_param("~period", 1.0)))
        self.max_lines = int(rospy.get_param("~max_lines", 10))
        self.last_print = None
        self.start = None
        self.seen = 0
        topic = rospy.get_param("~impacts_topic", "/vadop_monitor/impacts")
        self.sub = rospy.Subscriber(topic, ImpactArray, self.on_impacts, queue_size=5)

    def on_impacts(self, msg):
        self.seen += 1
        stamp = msg.header.stamp
        if self.start is None or (self.last_print is not None and stamp < self.last_print):
            self.start = stamp  # first message, or time jumped back (bag restarted)
            self.last_print = None
        if self.last_print is not None and stamp - self.last_print < self.period:
            return
        self.last_print = stamp
        t = (stamp - self.start).to_sec()
        if not msg.impacts:
            print("[t=%5.1f s] no impact predicted" % t, flush=True)
            return
        n = len(msg.impacts)
        lines = ["[t=%5.1f s] %d predicted impact%s:" % (t, n, "" if n == 1 else "s")]
        width = max(len(label(i.body_a, i.link_a)) for i in msg.impacts[:self.max_lines])
        for i in msg.impacts[:self.max_lines]:
            a = label(i.body_a, i.link_a).ljust(width)
            b = label(i.body_b, i.link_b)
            if i.in_contact:
                what = "in contact now"
            else:
                what = "in %.2f s at (%.2f, %.2f, %.2f), closing at %.2f m/s" % (
                    i.time_to_impact, i.point.x, i.point.y, i.point.z, i.closing_speed)
            lines.append("  %s <-> %s  %s" % (a, b.ljust(18), what))
        if n > self.max_lines:
            lines.append("  ... and %d more" % (n - self.max_lines))
        print("\n".join(lines), flush=True)


def main():
    rospy.init_node("impact_printer")
    Printer()
    rospy.spin()


if __name__ == "__main__":
    main()
