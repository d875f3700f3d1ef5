#!/usr/bin/python3
"""Measures vadop_monitor fed through ROS transport (launch/fleet_transport.launch) and prints:

  - node CPU: the monitor's user + system time (/proc/<pid>/stat; its pid from the XML-RPC
    getPid of ~pid_node: the monitor, or with nodelets the manager, whose process also runs the
    driver: then the CPU is theirs together) over the window, as a share of one core and per message (per odometry message in
    mode odom; per array and per entry in mode array; messages = n * rate * seconds, the
    driver's nominal load: its log says the rate it achieved);
  - the share of bodies fresh: "ok" in the monitor's "bodies" diagnostics summary, over ~n
    (the last report of the window, and the lowest one), and the time from the monitor's
    process start until a report first says every body is fresh (to within the diagnostics'
    period);
  - the cycle: mean, p95 and max from the "cycle" diagnostics, whose reports each cover about a
    second of cycles: the mean of their means, the mean of their p95s and the highest p95 (when
    every report's p95 is under a bound, about 5% of all cycles at most are over it: 1 in 30 at
    30 Hz), the highest max; and from each ImpactArray (stamped with its cycle's time) the time
    until it arrives here: mean and p95 (the cycle's work plus one transport hop), and the
    ImpactArray rate;
  - with ~sensors: each sensor's messages accepted and dropped over the window and its points
    kept at the end (the monitor's "sensors" diagnostics);
  - the age of the states: from each state message on the first robot's topic (read raw: only
    its header's stamp is decoded) the time until it arrives here, mean and p95 (a second
    subscriber of the same transport); a cycle uses a state of that age plus up to one driver
    period (on average half of it).
Private parameters: n (1000), rate (30, the driver's), mode (array | odom), seconds (20, the
window), warmup (5, before it), states_topic (/fleet/states), node (/vadop_monitor),
pid_node (~node: the node whose process is measured, e.g. /fleet_manager), driver_node (empty:
also measure this node's process, the driver in a process of its own: "driver CPU"),
state_age (true: measure the states' age, a second subscriber of their topic), sensors (false:
the monitor has sensors; report them), check (false: as a rostest, fail unless every figure was
measured and every body is fresh, and with sensors every sensor took messages and dropped none).
"""
import math
import os
import re
import struct
import sys
import time
import unittest
import xmlrpc.client

import rosgraph
import rospy
from diagnostic_msgs.msg import DiagnosticArray
from vadop.msg import ImpactArray


def percentile(values, p):
    if not values:
        return float("nan")
    v = sorted(values)
    return v[min(len(v) - 1, int(p * (len(v) - 1) + 0.5))]


def mean(values):
    return sum(values) / len(values) if values else float("nan")


def node_pid(node, timeout=120.0):
    """The pid of ROS node `node`, asked through its XML-RPC API (waits for it to register)."""
    master = rosgraph.Master("/fleet_report")
    deadline = time.time() + timeout
    while True:
        try:
            uri = master.lookupNode(node)
            break
        except rosgraph.MasterError:
            if time.time() > deadline or rospy.is_shutdown():
                raise
            time.sleep(0.5)
    code, _, pid = xmlrpc.client.ServerProxy(uri).getPid("/fleet_report")
    if code != 1:
        raise RuntimeError("getPid of %s failed" % node)
    return int(pid)


def start_time(pid):
    """Wall time (time.time()) at which process `pid` started."""
    with open("/proc/%d/stat" % pid) as f:
        ticks = int(f.read().rsplit(")", 1)[1].split()[19])  # starttime: field 22 of the line
    with open("/proc/uptime") as f:
        uptime = float(f.read().split()[0])
    return time.time() - (uptime - ticks / float(os.sysconf("SC_CLK_TCK")))


def cpu_seconds(pid):
    """User + system CPU seconds of process `pid` (all its threads)."""
    with open("/proc/%d/stat" % pid) as f:
        fields = f.read().rsplit(")", 1)[1].split()
    # After the command: state is field 3, utime 14 and stime 15 (1-based over the whole line).
    return (int(fields[11]) + int(fields[12])) / float(os.sysconf("SC_CLK_TCK"))


class Measure:
    def __init__(self):
        self.n = int(rospy.get_param("~n", 1000))
        self.rate = float(rospy.get_param("~rate", 30.0))
        self.mode = rospy.get_param("~mode", "array")
        self.seconds = float(rospy.get_param("~seconds", 20.0))
        self.warmup = float(rospy.get_param("~warmup", 5.0))
        self.node = rospy.get_param("~node", "/vadop_monitor")
        self.pid_node = rospy.get_param("~pid_node", self.node)
        self.driver_node = rospy.get_param("~driver_node", "")
        self.recording = False
        self.impact_delays, self.impact_times = [], []
        self.state_delays = []
        self.fresh = []  # (ok, summary) of each "bodies" report in the window
        self.cycle_means, self.cycle_p95s, self.cycle_maxes = [], [], []
        self.all_fresh_at, self.started_at = None, None  # wall times
        self.sensors = rospy.get_param("~sensors", False)
        self.sensor_values, self.sensor_start, self.sensor_end = {}, {}, {}  # "sensors" diagnostics
        states = rospy.get_param("~states_topic", "/fleet/states") if self.mode == "array" else "/robot_0/odom"
        self.subs = [
            rospy.Subscriber(self.node + "/impacts", ImpactArray, self.on_impacts, queue_size=50),
            rospy.Subscriber("/diagnostics", DiagnosticArray, self.on_diagnostics, queue_size=10),
        ]
        # Reading a large array costs this process CPU that the node's share of the machine may
        # miss: ~state_age false leaves the states' age out (reported as NaN).
        if rospy.get_param("~state_age", True):
            self.subs.append(rospy.Subscriber(states, rospy.AnyMsg, self.on_state, queue_size=50))

    def on_impacts(self, msg):
        if self.recording:
            self.impact_times.append(time.time())
            self.impact_delays.append(time.time() - msg.header.stamp.to_sec())

    def on_state(self, raw):
        # std_msgs/Header first: seq (uint32), stamp secs, nsecs (uint32 each).
        if self.recording:
            _, secs, nsecs = struct.unpack_from("<III", raw._buff, 0)
            self.state_delays.append(time.time() - (secs + nsecs * 1e-9))

    def on_diagnostics(self, msg):
        if self.all_fresh_at is None:
            for st in msg.status:
                m = re.match(r"(\d+) ok", st.message) if st.name.endswith(": bodies") else None
                if m and int(m.group(1)) >= self.n:
                    self.all_fresh_at = time.time()
        for st in msg.status:
            if st.name.endswith(": sensors"):
                self.sensor_values = {kv.key: kv.value for kv in st.values}
        if not self.recording:
            return
        for st in msg.status:
            if st.name.endswith(": bodies"):
                m = re.match(r"(\d+) ok", st.message)
                if m:
                    self.fresh.append((int(m.group(1)), st.message))
            elif st.name.endswith(": cycle"):
                values = {kv.key: kv.value for kv in st.values}
                if "cycle time mean (ms)" in values and int(values.get("cycles in window", "0")) > 0:
                    self.cycle_means.append(float(values["cycle time mean (ms)"]))
                    self.cycle_p95s.append(float(values.get("cycle time p95 (ms)", "nan")))
                    self.cycle_maxes.append(float(values["cycle time max (ms)"]))

    def run(self):
        pid = node_pid(self.pid_node)
        driver = node_pid(self.driver_node) if self.driver_node else None
        self.started_at = start_time(pid)
        rospy.sleep(self.warmup)
        self.recording = True
        self.sensor_start = dict(self.sensor_values)
        cpu0, t0 = cpu_seconds(pid), time.time()
        driver0 = cpu_seconds(driver) if driver else 0.0
        rospy.sleep(self.seconds)
        cpu1, t1 = cpu_seconds(pid), time.time()
        driver1 = cpu_seconds(driver) if driver else 0.0
        self.recording = False
        self.sensor_end = dict(self.sensor_values)
        f = self.figures(cpu1 - cpu0, t1 - t0)
        if driver:
            f["driver_cpu_share"] = (driver1 - driver0) / (t1 - t0)
        return f

    def figures(self, cpu, wall):
        arrays = self.rate * wall
        messages = self.n * arrays if self.mode == "odom" else arrays
        f = {
            "cpu_share": cpu / wall,
            "cpu_us_per_message": cpu / messages * 1e6,
            "cpu_us_per_body_state": cpu / (self.n * arrays) * 1e6,
            "fresh_share_last": self.fresh[-1][0] / float(self.n) if self.fresh else float("nan"),
            "fresh_share_min": min(ok for ok, _ in self.fresh) / float(self.n) if self.fresh else float("nan"),
            "cycle_mean_ms": mean(self.cycle_means),
            "cycle_p95_ms": mean(self.cycle_p95s),
            "cycle_p95_max_ms": max(self.cycle_p95s) if self.cycle_p95s else float("nan"),
            "cycle_max_ms": max(self.cycle_maxes) if self.cycle_maxes else float("nan"),
            "impacts_delay_mean_ms": mean(self.impact_delays) * 1e3,
            "impacts_delay_p95_ms": percentile(self.impact_delays, 0.95) * 1e3,
            "impacts_rate_hz": (len(self.impact_times) - 1) / (self.impact_times[-1] - self.impact_times[0])
            if len(self.impact_times) > 1 else float("nan"),
            "state_delay_mean_ms": mean(self.state_delays) * 1e3,
            "state_delay_p95_ms": percentile(self.state_delays, 0.95) * 1e3,
        }
        f["state_age_at_cycle_mean_ms"] = f["state_delay_mean_ms"] + 0.5e3 / self.rate
        if self.sensors:
            for name in self.sensorNames():
                for what in ("messages accepted", "messages dropped"):
                    key = "%s: %s" % (name, what)
                    f["sensor %s" % key] = (float(self.sensor_end.get(key, "nan")) -
                                            float(self.sensor_start.get(key, "nan")))
                f["sensor %s: points" % name] = float(self.sensor_end.get("%s: points" % name, "nan"))
            if not self.sensorNames():
                f["sensors"] = float("nan")  # no "sensors" diagnostics seen
        return f

    def sensorNames(self):
        return sorted(k[:-len(": messages accepted")] for k in self.sensor_end if k.endswith(": messages accepted"))

    def report(self, f):
        lines = [
            "fleet_report: mode %s, %d robots at %.1f Hz, %.0f s measured after %.0f s" %
            (self.mode, self.n, self.rate, self.seconds, self.warmup),
            "  %s: %.1f%% of a core; %.2f us per %s; %.3f us per body state" %
            ("node CPU" if self.pid_node == self.node else
             "node CPU (the process of %s: the monitor and the driver)" % self.pid_node, 100 * f["cpu_share"], f["cpu_us_per_message"], "odometry message" if self.mode == "odom" else "array",
             f["cpu_us_per_body_state"]),
            "  bodies fresh: %.1f%% (last report), %.1f%% (lowest in window); last: %s" %
            (100 * f["fresh_share_last"], 100 * f["fresh_share_min"], self.fresh[-1][1] if self.fresh else "none"),
            "  cycle (diagnostics): mean %.2f ms, p95 %.2f ms (mean of the reports'; highest %.2f ms), max %.2f ms" %
            (f["cycle_mean_ms"], f["cycle_p95_ms"], f["cycle_p95_max_ms"], f["cycle_max_ms"]),
            "  ImpactArray: %.2f Hz; cycle start to arrival here: mean %.2f ms, p95 %.2f ms" %
            (f["impacts_rate_hz"], f["impacts_delay_mean_ms"], f["impacts_delay_p95_ms"]),
            "  states: stamp to arrival here mean %.2f ms, p95 %.2f ms; age at a cycle about %.1f ms on average" %
            (f["state_delay_mean_ms"], f["state_delay_p95_ms"], f["state_age_at_cycle_mean_ms"]),
        ]
        if "driver_cpu_share" in f:
            lines.insert(2, "  driver CPU (the process of %s): %.1f%% of a core" % (self.driver_node, 100 * f["driver_cpu_share"]))
        for name in self.sensorNames() if self.sensors else []:
            lines.append("  sensor %s: %.0f messages accepted, %.0f dropped in the window; %.0f points kept" %
                         (name, f["sensor %s: messages accepted" % name], f["sensor %s: messages dropped" % name],
                          f["sensor %s: points" % name]))
        if self.all_fresh_at is not None and self.started_at is not None:
            lines.append("  start-up: every body fresh %.1f s after the monitor started" %
                         (self.all_fresh_at - self.started_at))
        else:
            lines.append("  start-up: not every body fresh within the run")
        print("\n".join(lines))
        sys.stdout.flush()
        return "\n".join(lines)


class FleetTransportSmoke(unittest.TestCase):
    """The rostest: every figure measured (none NaN) and every body fresh at the end."""

    def test_figures_and_fresh_bodies(self):
        m = Measure()
        f = m.run()
        text = m.report(f)
        for key, value in f.items():
            self.assertFalse(math.isnan(value), "%s not measured:\n%s" % (key, text))
        self.assertEqual(f["fresh_share_last"], 1.0, text)
        self.assertTrue(0.0 < f["cycle_p95_ms"] <= f["cycle_p95_max_ms"] <= f["cycle_max_ms"], text)
        self.assertIn("node CPU", text)
        for name in m.sensorNames() if m.sensors else []:
            self.assertGreater(f["sensor %s: messages accepted" % name], 0, text)
            self.assertEqual(f["sensor %s: messages dropped" % name], 0, text)


def main():
    rospy.init_node("fleet_report")
    if rospy.get_param("~check", False):
        import rostest
        rostest.rosrun("vadop", "fleet_transport_smoke", FleetTransportSmoke)
        return
    m = Measure()
    m.report(m.run())


if __name__ == "__main__":
    main()
