#!/usr/bin/env python3
"""Scenario rostests, part 1 (a plain node of test/scenario_*.test): generates the scenario's bag
and ground truth deterministically into ~workdir (test/scenario_gen.py), waits until every
monitor has subscribed, plays the bag with `rosbag play --clock`, records what the monitors
publish (~impacts of each, /diagnostics) and writes it to ~workdir/record.json when the bag
has ended. test/scenario_check.py (the test node) then checks the record against the truth.

Parameters: ~scenario (path of the yaml), ~workdir, ~monitors (node names, default
[vadop_monitor]), ~clock_hz (rosbag play --hz, default 200), ~delay (s, rosbag play -d, default 0),
~connect_timeout (s, default 60).
Start of the bag: rosbag play starts paused (--pause) and is resumed (a space on its stdin) only
once every monitor is connected to every topic of the bag it subscribes to, and to /clock, as
rosbag play's own getBusInfo shows (an outgoing link exists once the subscriber's connection
header has arrived). A fixed delay is not enough: with 200 topics, a few of the connections of
the burst that follows the advertisements can take several seconds on a loaded machine (listen
queues overflow, the kernel retries the connection 1, 3, 7 s later), and the monitor then never
sees those bodies' first seconds (the crowd scenario missed their impacts). Topics still
unconnected after ~connect_timeout are written to the record (unconnected_at_start), and
scenario_check.py reports them.
Why a node of its own: the test node (scenario_check.py) only reads the record, so that the same
checks apply to any record; after the bag this node keeps /clock running (real-time rate), so
that the monitor keeps cycling (and shows it is still alive) until the check has ended. The
cadence is checked on the arrays' stamps, not by rostest's hztest: hztest starts its sim-time
measurement at the first message it receives, and when its /clock subscription connects later
than that (a loaded machine) it ends at once, and rostest tears the launch down mid-bag. A launch
started again for the same rostest run (rostest's retry) finds record.json in ~workdir and only waits.
Work directory: ~workdir is /tmp/$(anon vadop_scenario) in the .test files; rostest parses the file
once per run (one anonymous name, with rostest's pid, shared by every launch of that run; a new one
for the next run). It is removed by scenario_check.py when the checks pass, and only
once this launch's player has set ~state to "idle" (it found the record and will not touch the
directory again) or "recorded" (it wrote the record): the player of that launch may start after the
checker, and would otherwise find no record, then regenerate and replay the bag into a new
directory left behind in /tmp. A failing check keeps the directory for inspection and says so.
"""
import json
import os
import signal
import subprocess
import sys
import threading
import time
import xmlrpc.client

import rosgraph
import rospy
from diagnostic_msgs.msg import DiagnosticArray
from rosgraph_msgs.msg import Clock
from vadop.msg import ImpactArray

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import scenario_gen  # noqa: E402


def log(s):
    rospy.loginfo("scenario_player: %s", s)


def outgoing_links(master, node):
    """(topic, subscriber node) of every link `node` publishes on (its getBusInfo), or None."""
    try:
        code, _, info = xmlrpc.client.ServerProxy(master.lookupNode(node)).getBusInfo("/scenario_player")
    except Exception:  # noqa: BLE001  (the node not registered yet, or gone)
        return None
    if code != 1:
        return None
    return {(row[4], row[1]) for row in info if len(row) > 4 and row[2] == "o"}


def set_state(state):
    """~state = "<state>|<this node's XML-RPC URI>" (see the module docstring: scenario_check.py waits for it
    before it removes ~workdir; the URI tells this launch's player from a previous launch's on a reused master)."""
    rospy.set_param("~state", "%s|%s" % (state, rospy.get_node_uri()))


def main():
    rospy.init_node("scenario_player")
    path = rospy.get_param("~scenario")
    workdir = rospy.get_param("~workdir")
    monitors = rospy.get_param("~monitors", ["vadop_monitor"])
    clock_hz = float(rospy.get_param("~clock_hz", 200.0))
    delay = float(rospy.get_param("~delay", 0.0))
    connect_timeout = float(rospy.get_param("~connect_timeout", 60.0))
    os.makedirs(workdir, exist_ok=True)
    if os.path.exists(os.path.join(workdir, "record.json")):
        rospy.loginfo("scenario_player: %s already has the record: nothing to do", workdir)
        set_state("idle")  # from here on this node never touches workdir: scenario_check may remove it
        rospy.spin()
        return
    wall0 = time.time()

    lock = threading.Lock()
    arrays = {m: [] for m in monitors}
    diags = []

    def on_impacts(msg, mon):
        row = [msg.header.stamp.to_sec(),
               [[i.body_a, i.link_a, i.body_b, i.link_b, i.time_to_impact, bool(i.in_contact), i.closing_speed,
                 (i.time_of_impact - msg.header.stamp).to_sec()] for i in msg.impacts]]
        with lock:
            arrays[mon].append(row)

    def on_diag(msg):
        rows = [[msg.header.stamp.to_sec(), s.name, int(s.level) if not isinstance(s.level, bytes) else s.level[0],
                 s.message, {kv.key: kv.value for kv in s.values}] for s in msg.status]
        with lock:
            diags.extend(rows)

    subs = [rospy.Subscriber("/%s/impacts" % m, ImpactArray, on_impacts, callback_args=m, queue_size=1000,
                             tcp_nodelay=True) for m in monitors]
    subs.append(rospy.Subscriber("/diagnostics", DiagnosticArray, on_diag, queue_size=1000))

    sc = scenario_gen.Scenario(path)
    bag = os.path.join(workdir, "scenario.bag")
    sc.write_bag(bag, log)
    for m in monitors:
        padding = float(rospy.get_param("/%s/padding" % m, 0.0))
        horizon = float(rospy.get_param("/%s/horizon" % m, 2.0))
        truth = sc.truth(padding, sc.duration + horizon + 0.5, log)
        with open(os.path.join(workdir, "truth_%s.json" % m), "w") as f:
            json.dump(truth, f)
    gen_wall = time.time() - wall0

    # Every monitor up and subscribed to every odometry topic; our subscribers connected.
    master = rosgraph.Master("/scenario_player")
    topics = sorted({b.topic for b in sc.bodies})
    # and to the trackers the monitors take (their `tracks` sources)
    tracker_topics = sorted({t.topic for t in sc.trackers if t.in_node})
    deadline = time.time() + 60.0
    while not rospy.is_shutdown():
        _, subscribers, _ = master.getSystemState()
        subs_of = {t: set(nodes) for t, nodes in subscribers}
        ready = all(all("/" + m in subs_of.get(t, ()) for t in topics + tracker_topics) for m in monitors)
        ready = ready and all(s.get_num_connections() > 0 for s in subs[:-1])
        if ready or time.time() > deadline:
            break
        time.sleep(0.1)
    if not ready:
        rospy.logerr("scenario_player: the monitors did not subscribe within 60 s (to %s)" % ", ".join(
            topics + tracker_topics))

    clock_pub = rospy.Publisher("/clock", Clock, queue_size=10)  # used after the bag only
    # Paused until every monitor is connected to the bag's topics (see the module docstring).
    cmd = ["rosbag", "play", "--clock", "--hz=%g" % clock_hz, "-d", "%g" % delay, "--pause", "-q", bag]
    log("playing: %s" % " ".join(cmd))
    play_start = time.time()
    proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, start_new_session=True)

    def stop_player():
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGINT)
    rospy.on_shutdown(stop_player)
    import rosbag  # slow to import: only here (a relaunch must see record.json at once)
    with rosbag.Bag(bag) as b:
        bag_topics = set(b.get_type_and_topic_info().topics) | {"/clock"}
    missing = {}
    deadline = time.time() + connect_timeout
    while not rospy.is_shutdown() and proc.poll() is None:
        publishers, subscribers, _ = master.getSystemState()
        subs_of = {t: set(nodes) for t, nodes in subscribers}
        # rosbag play's node (anonymous: /play_<n>), found as a publisher of the bag's first topic
        player = next((n for t, nodes in publishers if t == topics[0] for n in nodes if n.startswith("/play_")), None)
        links = outgoing_links(master, player) if player else None
        if links is None:
            missing = {m: ["(no rosbag play node answering getBusInfo)"] for m in monitors}
        else:
            missing = {m: sorted(t for t in bag_topics if "/" + m in subs_of.get(t, ()) and (t, "/" + m) not in links)
                       for m in monitors}
            missing = {m: t for m, t in missing.items() if t}
            if not missing:
                break
        if time.time() > deadline:
            rospy.logerr("scenario_player: after %.0f s, %s: starting the bag anyway" % (connect_timeout, "; ".join(
                "%s not connected to %d topic(s) (%s)" % (m, len(t), ", ".join(t[:5])) for m, t in missing.items())))
            break
        time.sleep(0.05)
    connect_wall = time.time() - play_start
    log("monitors connected to every topic after %.2f s: resuming the bag" % connect_wall if not missing else
        "resuming the bag with topics unconnected")
    try:
        proc.stdin.write(b" ")  # rosbag play: a space toggles pause
        proc.stdin.flush()
    except OSError:
        pass  # rosbag play already ended: its exit status tells
    rc = proc.wait()
    play_wall = time.time() - play_start
    # Keep the clock going (from the bag's end, real-time rate) until roslaunch stops us.
    end = rospy.Time.from_sec(scenario_gen.T0 + sc.duration)
    stop = threading.Event()

    def run_clock():
        start = time.time()
        while not stop.is_set() and not rospy.is_shutdown():
            try:
                clock_pub.publish(Clock(clock=end + rospy.Duration.from_sec(time.time() - start)))
            except rospy.ROSException:
                return  # the topic closed: roslaunch is shutting this node down
            time.sleep(1.0 / clock_hz)
    threading.Thread(target=run_clock, daemon=True).start()
    time.sleep(0.5)  # the last messages in flight
    alive = {}
    for m in monitors:
        try:
            master.lookupNode("/" + m)
            alive[m] = True
        except Exception:  # noqa: BLE001
            alive[m] = False
    with lock:
        record = {"scenario": sc.name, "monitors": arrays, "diagnostics": diags, "rosbag_play_rc": rc,
                  "generate_wall_s": gen_wall, "play_wall_s": play_wall, "alive_after_bag": alive,
                  "connect_wall_s": connect_wall, "unconnected_at_start": missing}
        tmp = os.path.join(workdir, "record.json.tmp")
        with open(tmp, "w") as f:
            json.dump(record, f)
        os.replace(tmp, os.path.join(workdir, "record.json"))
    set_state("recorded")
    log("done: bag played in %.1f s (rc %d), %s" % (play_wall, rc, ", ".join(
        "%s: %d arrays" % (m, len(a)) for m, a in arrays.items())))
    rospy.spin()  # stay until roslaunch ends the test
    stop.set()


if __name__ == "__main__":
    main()
