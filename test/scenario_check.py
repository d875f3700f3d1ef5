#!/usr/bin/env python3
"""Scenario rostests, part 2 (the test node of test/scenario_*.test): waits for
test/scenario_player.py's record of the played bag and checks each monitor's ~impacts and
/diagnostics against the scenario's ground truth (test/scenario_gen.py, test/ground_truth.py).

Per monitor (its horizon H, rate f and padding p read from the parameter server), with times in
scenario seconds and T a pair's true first contact (shapes grown by p):
 1. every true impact is reported before it happens (a cycle with stamp < T names the pair),
    unless T comes before the monitor's first cycle can know both bodies;
 2. when both bodies moved as the monitor models them (constant twist, no driving turn,
    constant joint rates, messages flowing; or along the path a body publishes) over [T - H, T]
    (from clean_since plus one message period and LATENCY), the first report is at least
    H - 1/f - CLOCK_TOL - E ahead (CLOCK_TOL: the granularity of rosbag play's /clock, on which
    the node's timer fires; E: the pair's largest time_to_impact error in that window, which
    rule 3 bounds by the time tolerance: with noisy odometry a prediction late by E is announced
    up to E later; 0 without noise);
 3. on those windows, every report's stamp + time_to_impact is within the time tolerance of T:
    TIME_TOL (50 ms), or the scenario's `expect: {time_tol: s}` (e.g. 0.02 for 20 ms);
 4. no reported pair (body/link with body/link) that the truth under padding p does not have
    (cycles within the bag: after it every body goes stale and stands still);
 5. the node lived through the bag: cycles until the bag's end, no gap above 3 periods;
 6. the scenario's `expect:` entries: pairs that must / must not collide, a minimum number of
    impacts, and /diagnostics statuses (e.g. the stale or bad body named, the others ok);
 7. with a tracker (scenario `tracker:`, issue 17): an object whose life ended in the bag is named
    by no impact array stamped later than its end + its source's timeout + 2 cycles (until the
    id's next life); the scenario has no ghost contact (an object that left, going on straight or
    standing still, touching a body while a monitor may still hold it: a design error); the
    monitor's "<monitor>: tracks" status on /diagnostics has every "<prefix>: ..." key, a summary
    "N tracked objects from M source(s)", "<prefix>: objects" within the truth's bounds (at least
    the objects alive well around the stamp, at most those alive or left less than the timeout
    before) and above 0 at some point, and "<prefix>: objects dropped" above 0 when the tracker
    sends NaN objects. A pair may have one truth entry per life of a reused id ("exists_since"):
    each is checked on the reports from that life's start on.
`expect:` keys: impacts, no_impacts ([[body, body], ...]), min_impacts, time_tol (rule 3's
tolerance, s), diagnostics, tracks ([{prefix, min: {"<prefix>: <key>": n}}]: the largest value
of those diagnostics keys), and monitors: {<monitor>: {...}} (per-monitor overrides of the pair
keys and time_tol).
It prints one summary line per monitor (and per impact for small scenarios), and writes them
to $ROS_TEST_RESULTS_DIR/vadop/scenario_summary/<scenario>.txt.

Work directory (~workdir, shared by every launch of one rostest run, see scenario_player.py): it
waits for the player's record.json there (~timeout, default 240 s). When every check passed, it
removes ~workdir, but only once the scenario_player of its own launch (~player) has set its ~state
(it has seen the record and will not regenerate it); when a check failed, it keeps ~workdir for
inspection, says so in the failure message and writes KEPT_FOR_INSPECTION.txt there.
"""
import json
import os
import re
import shutil
import sys
import time
import unittest

import rosgraph
import rospy
import rostest
import yaml

TIME_TOL = 0.05
LATENCY = 0.02
NAME = "scenario_check"


def key(a, la, b, lb):
    x, y = (a, la), (b, lb)
    return (x, y) if x <= y else (y, x)


def label(k):
    return " <-> ".join(b + ("/" + l if l else "") for b, l in k)


def body_key(a, b):
    return tuple(sorted((a, b)))


class ScenarioCheck(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node(NAME)
        cls.workdir = rospy.get_param("~workdir")
        cls.monitors = rospy.get_param("~monitors", ["vadop_monitor"])
        cls.clock_hz = float(rospy.get_param("~clock_hz", 200.0))
        with open(rospy.get_param("~scenario")) as f:
            cls.spec = yaml.safe_load(f)
        cls.expect = cls.spec["scenario"].get("expect", {}) or {}
        cls.player = rospy.get_param("~player", "scenario_player")
        path = os.path.join(cls.workdir, "record.json")
        deadline = time.time() + float(rospy.get_param("~timeout", 240.0))
        while not os.path.exists(path) and time.time() < deadline and not rospy.is_shutdown():
            time.sleep(0.2)
        # (When setUpClass fails, unittest skips tearDownClass: the directory stays.)
        if not os.path.exists(path):
            raise AssertionError("no record from scenario_player in %s%s" % (cls.workdir, cls.kept()))
        try:
            with open(path) as f:
                cls.record = json.load(f)
            cls.truths = {}
            for m in cls.monitors:
                with open(os.path.join(cls.workdir, "truth_%s.json" % m)) as f:
                    cls.truths[m] = json.load(f)
        except (OSError, ValueError) as e:
            raise AssertionError("cannot read scenario_player's record or truth: %s%s" % (e, cls.kept())) from e
        cls.summary = []  # per monitor: the one-line summary (then per-impact lines)
        cls.diag_summary = []  # after them, whatever order unittest runs the tests in
        cls.failed = False

    @classmethod
    def kept(cls):
        """The failure message's note that the work directory stays."""
        return "\n(work directory kept for inspection: %s)" % cls.workdir

    @classmethod
    def wait_for_player(cls, timeout=45.0):
        """True once the player of this launch has set ~state ("idle": it found the record, or
        "recorded": it wrote it) with its own URI: from then on it never touches the work directory."""
        master = rosgraph.Master(rospy.get_name())
        name = rosgraph.names.ns_join("/", cls.player)
        deadline = time.time() + timeout
        while time.time() < deadline:
            try:
                uri = master.lookupNode(name)
                state, _, who = str(master.getParam(name + "/state")).partition("|")
                if who == uri and state in ("idle", "recorded"):
                    return True
            except Exception:  # noqa: BLE001  (not registered yet, no ~state yet, or the master gone)
                pass
            time.sleep(0.1)
        return False

    @classmethod
    def tearDownClass(cls):
        name = cls.record["scenario"]
        text = "\n".join(cls.summary + cls.diag_summary) + "\n"
        print(text)
        base = os.environ.get("ROS_TEST_RESULTS_DIR") or os.path.expanduser("~/.ros/test_results")
        out = os.path.join(base, "vadop", "scenario_summary")
        try:
            os.makedirs(out, exist_ok=True)
            with open(os.path.join(out, name + ".txt"), "w") as f:
                f.write(text)
        except OSError as e:
            print("cannot write the summary: %s" % e)
        if cls.failed:
            print("scenario_check: work directory kept for inspection: %s" % cls.workdir)
            try:
                with open(os.path.join(cls.workdir, "KEPT_FOR_INSPECTION.txt"), "w") as f:
                    f.write("scenario %s failed its checks; this directory (bag, truth, record) is kept on purpose and "
                            "may be removed by hand.\n%s" % (name, text))
            except OSError:
                pass
            return
        if not cls.wait_for_player():
            print("scenario_check: %s did not report its state within 45 s (dead?); removing %s anyway"
                  % (cls.player, cls.workdir))
        shutil.rmtree(cls.workdir, ignore_errors=True)

    def run(self, result=None):
        r = super().run(result)
        if result is not None and (result.failures or result.errors):
            type(self).failed = True
        return r

    # ------------------------------------------------------------------ impacts
    def check_monitor(self, mon):
        truth = self.truths[mon]
        t0 = truth["t0"]
        duration = truth["duration"]
        horizon = float(rospy.get_param("/%s/horizon" % mon))
        rate = float(rospy.get_param("/%s/rate" % mon))
        padding = truth["padding"]
        arrays = self.record["monitors"][mon]
        errors = []
        unconnected = (self.record.get("unconnected_at_start") or {}).get(mon)
        if unconnected:
            errors.append("test harness: the bag started before %s was connected to %d of its topics (%s): the "
                          "checks below see it miss those bodies' first messages"
                          % (mon, len(unconnected), ", ".join(unconnected[:8])))
        self.assertGreater(len(arrays), 0, "%s published no ImpactArray%s" % (mon, self.kept()))
        stamps = [a[0] - t0 for a in arrays]
        first_cycle, last_cycle = stamps[0], stamps[-1]
        in_bag = [s for s in stamps if s <= duration]
        gaps = [b - a for a, b in zip(in_bag[:-1], in_bag[1:])]
        max_gap = max(gaps) if gaps else 0.0
        if last_cycle < duration - 0.1:
            errors.append("%s: last cycle at %.3f s, the bag lasts %.3f s: the node stopped" % (mon, last_cycle, duration))
        if max_gap > 3.0 / rate:
            errors.append("%s: %.3f s without an ImpactArray (period %.3f s)" % (mon, max_gap, 1.0 / rate))
        # The cadence in sim time over the bag: within 10% of ~rate on average (the node's timer).
        span = in_bag[-1] - in_bag[0] if len(in_bag) > 1 else 0.0
        mean_rate = (len(in_bag) - 1) / span if span > 0.0 else 0.0
        if span < 0.5 * duration or abs(mean_rate - rate) > 0.1 * rate:
            errors.append("%s: %d arrays over %.3f s of the bag (%.2f Hz), %.1f Hz expected"
                          % (mon, len(in_bag), span, mean_rate, rate))
        if any(b < a for a, b in zip(stamps[:-1], stamps[1:])):
            errors.append("%s: ImpactArray stamps go backwards" % mon)

        reports = {}
        for s, impacts in arrays:
            s -= t0
            tts = [i[4] for i in impacts]
            if tts != sorted(tts):
                errors.append("%s: impacts at %.3f s not sorted by time_to_impact" % (mon, s))
            for a, la, b, lb, tti, contact, closing, toi in impacts:
                if abs(toi - tti) > 1e-6:
                    errors.append("%s: time_of_impact - stamp = %.6f != time_to_impact %.6f" % (mon, toi, tti))
                reports.setdefault(key(a, la, b, lb), []).append((s, tti, contact))
        # One entry per pair; a tracked object's id reused for a second life may give a pair one entry per
        # life ("exists_since": the later of the two lives' starts): each is checked on the reports since then.
        truth_pairs = {}
        for p in sorted(truth["pairs"], key=lambda p: p["t"]):
            truth_pairs.setdefault(key(p["a"], p["la"], p["b"], p["lb"]), {}).setdefault(p.get("exists_since"), p)
        truth_list = sorted((p for lives in truth_pairs.values() for p in lives.values()), key=lambda p: p["t"])
        exp = dict(self.expect)
        exp.update((self.expect.get("monitors", {}) or {}).get(mon, {}) or {})
        time_tol = float(exp.get("time_tol", TIME_TOL))

        # Once the bag has ended, every body goes stale (standing still): only cycles within the bag count.
        false = sorted(k for k in reports if k not in truth_pairs and reports[k][0][0] <= duration)
        for k in false:
            r = reports[k][0]
            errors.append("%s: %s reported (first at %.3f s, in %.3f s, %d cycles) but the truth (padding %.3f m) has "
                          "no contact" % (mon, label(k), r[0], r[1], len(reports[k]), padding))

        clock_tol = 1.0 / self.clock_hz + 0.001
        n_rule = n_checked = n_reported = n_skipped = 0
        min_warning = None
        worst = 0.0
        worst_rotating = 0.0
        details = []
        for p in truth_list:
            k = key(p["a"], p["la"], p["b"], p["lb"])
            T = p["t"]
            if T > last_cycle:
                n_skipped += 1
                continue
            since = p.get("exists_since")
            before = [r for r in reports.get(k, []) if r[0] < T and (since is None or r[0] >= since)]
            knowable = max(first_cycle, p["clean_since"]) + p["msg_delay"] + LATENCY + 1.0 / rate
            if not before:
                if T <= knowable:
                    n_skipped += 1
                    continue
                errors.append("%s: %s collides at %.4f s but was never reported before" % (mon, label(k), T))
                details.append("  %-40s T=%7.3f s  MISSED" % (label(k), T))
                continue
            n_reported += 1
            warning = T - before[0][0]
            clean_from = max(p["clean_since"], first_cycle) + p["msg_delay"] + LATENCY
            rule = clean_from <= T - horizon
            errs = [(abs(s + tti - T), s) for s, tti, _ in before if s >= clean_from]
            pair_worst = max(errs)[0] if errs else None
            if rule:
                n_rule += 1
                min_warning = warning if min_warning is None else min(min_warning, warning)
                # A prediction late by e (odometry noise) is announced up to e later.
                need = horizon - 1.0 / rate - clock_tol - (pair_worst or 0.0)
                # The node's timer may fire late on a loaded machine (the gap between two cycles then
                # exceeds 1/f + CLOCK_TOL): what counts is that the first cycle whose horizon reaches
                # T (stamp >= T - H + e, 1 ms slack) reported it.
                due = next((c for c in in_bag if c >= T - horizon + (pair_worst or 0.0) + 0.001), None)
                if due is not None:
                    need = min(need, T - due)
                if warning < need:
                    errors.append("%s: %s first reported %.4f s before contact at %.4f s; constant velocities over the "
                                  "horizon: at least %.4f s expected" % (mon, label(k), warning, T, need))
            if errs:
                n_checked += len(errs)
                if p["rotating"]:
                    worst_rotating = max(worst_rotating, pair_worst)
                else:
                    worst = max(worst, pair_worst)
                e, s = max(errs)
                if e > time_tol:
                    bad = [(s_, tti) for s_, tti, _ in before if s_ >= clean_from and abs(s_ + tti - T) > time_tol]
                    errors.append("%s: %s: time_to_impact off by %.1f ms at %.3f s (true contact %.4f s, %.2f s ahead; "
                                  "%d of %d reports beyond %.0f ms, the last %.2f s ahead)%s"
                                  % (mon, label(k), 1e3 * e, s, T, T - s, len(bad), len(errs), 1e3 * time_tol,
                                     T - bad[-1][0], " (rotating link)" if p["rotating"] else ""))
            why = " (velocity change in the window)"
            if since is not None and p["clean_since"] <= since + 1e-9:
                why = " (seen %.2f s before)" % (T - since)
            details.append("  %-40s T=%7.3f s  first warning %.3f s ahead%s  max |err| %s%s"
                           % (label(k), T, warning, "" if rule else why,
                              "%.1f ms" % (1e3 * pair_worst) if pair_worst is not None else "n/a",
                              " (rotating)" if p["rotating"] else ""))

        # Scenario expectations on pairs.
        truth_bodies = {body_key(p["a"], p["b"]) for p in truth["pairs"]}
        reported_bodies = {body_key(k[0][0], k[1][0]) for k in reports}
        for a, b in exp.get("impacts", []) or []:
            if body_key(a, b) not in truth_bodies:
                errors.append("%s: scenario design: %s and %s must collide, the truth says they do not" % (mon, a, b))
            if body_key(a, b) not in reported_bodies:
                errors.append("%s: %s <-> %s never reported" % (mon, a, b))
        for a, b in exp.get("no_impacts", []) or []:
            if body_key(a, b) in truth_bodies:
                errors.append("%s: scenario design: %s and %s must not collide, the truth says they do" % (mon, a, b))
            if body_key(a, b) in reported_bodies:
                errors.append("%s: %s <-> %s reported, they never collide" % (mon, a, b))
        if len(truth["pairs"]) < int(exp.get("min_impacts", 0)):
            errors.append("%s: scenario design: %d true impacts, at least %d expected"
                          % (mon, len(truth["pairs"]), exp["min_impacts"]))

        line = ("scenario %s [%s: H %.2f s, %.0f Hz, padding %.3f m]: %d true impacts, %d reported before contact, "
                "%d not checkable (at the start or after the end); earliest warning min %s over %d constant-velocity "
                "window(s) (rule >= %.3f s); max |time_to_impact error| %.1f ms over %d reports%s (tolerance %.0f ms); "
                "%d false pair(s); %d arrays (%.2f Hz in the bag), max gap %.0f ms; connected to every topic %.2f s "
                "after rosbag play started"
                % (truth["scenario"], mon, horizon, rate, padding, len(truth_list), n_reported, n_skipped,
                   "%.3f s" % min_warning if min_warning is not None else "n/a", n_rule, horizon - 1.0 / rate - clock_tol,
                   1e3 * worst, n_checked,
                   ", %.1f ms on rotating links" % (1e3 * worst_rotating) if worst_rotating else "", 1e3 * time_tol,
                   len(false), len(arrays), mean_rate, 1e3 * max_gap, self.record.get("connect_wall_s", float("nan"))))
        self.summary.append(line)
        if len(details) <= 12 or truth.get("tracks"):
            self.summary.extend(details)
        if truth.get("tracks"):
            errors.extend(self.check_tracks(mon, truth, arrays, rate, duration))
        return errors

    # ------------------------------------------------------------------ tracked objects (issue 17)
    def check_tracks(self, mon, truth, arrays, rate, duration):
        """Objects of a tracker (scenario `tracker:`) that left (their life ended in the bag) must be
        out of the monitor's world once their source's timeout has passed: no impact array stamped
        later than the life's end + timeout + 2 cycles (and before the id's next life) names them.
        Also: no ghost contact in the scenario's design (see scenario_gen.py: an object that left,
        going on straight or standing still, touching another body while a monitor may still hold it
        and predict it: such a report would be legitimate, the truth has no such pair)."""
        errors = []
        t0 = truth["t0"]
        for g in truth.get("ghost_contacts", []) or []:
            errors.append("%s: scenario design: %s leaves at %.3f s, but %s it would touch %s at %.3f s, within "
                          "the time a monitor may still hold and predict it (%.3f s): move it"
                          % (mon, g["body"], g["life_end"], "going on straight" if g["model"] == "straight"
                             else "standing still", g["other"], g["t"], g["window"]))
        windows = []  # (body, life end, from, to)
        for name, info in sorted(truth["tracks"].items()):
            lives = info["lives"]
            for n, (on, off) in enumerate(lives):
                if off is None or off >= duration:
                    continue
                nxt = lives[n + 1][0] if n + 1 < len(lives) else float("inf")
                windows.append((name, off, off + float(info["timeout"]) + 2.0 / rate, nxt))
        late = {}  # (body, life end) -> [(stamp, other)]
        for s, impacts in arrays:
            s -= t0
            for a, la, b, lb, tti, contact, closing, toi in impacts:
                for name, off, lo, hi in windows:
                    if lo < s < hi and name in (a, b):
                        late.setdefault((name, off), []).append((s, b if a == name else a, tti))
        n_late = sum(len(v) for v in late.values())
        for (name, off), rows in sorted(late.items(), key=lambda kv: kv[1][0][0]):
            info = truth["tracks"][name]
            errors.append("%s: %s left at %.3f s (timeout %.2f s) but %d impact(s) name it from %.3f s on (first: with "
                          "%s, in %.3f s; last at %.3f s): it stayed in the monitor's world"
                          % (mon, name, off, info["timeout"], len(rows), rows[0][0], rows[0][1], rows[0][2], rows[-1][0]))
        for tr in truth.get("trackers", []) or []:
            self.summary.append(
                "  tracks %s (%s, %.0f Hz, timeout %.2f s): %d objects, %d lives, %d left in the bag; %d impact(s) "
                "naming an object after it left (rule: stamp > end + timeout + 2 cycles); %d always-NaN object(s), %d NaN "
                "copies, %d duplicate id(s); %d ghost contact(s) in the design"
                % (tr["prefix"], tr["topic"], tr["rate"], tr["timeout"], tr["objects"], tr["lives"],
                   sum(1 for w in windows if w[0].startswith(tr["prefix"] + "/")), n_late, tr["nan_objects"],
                   tr["nan_copies"], tr["decoys"], len(truth.get("ghost_contacts", []) or [])))
        return errors

    def check_track_diagnostics(self, mon, tr, truth, rows, rate):
        """The monitor's "tracks" status on /diagnostics for the tracker tr (truth's "trackers" entry): present,
        with every per-source key; "<prefix>: objects" within what the truth allows (objects alive well around
        the status's stamp at least, those alive or still held at most) and above 0 at some point; objects
        dropped above 0 when the tracker sends NaN objects; the scenario's `expect: tracks` minimums."""
        errors = []
        P = tr["prefix"]
        keys = ["objects", "arrays accepted", "arrays dropped", "objects dropped", "objects expired", "last problem"]
        if not rows:
            return ["%s: no 'tracks' status on /diagnostics" % mon]
        duration = truth["duration"]
        margin = 0.2 + 2.0 / rate  # the status's stamp against the moment its counts were taken
        lives = [(on, duration if off is None else min(off, duration), float(info["timeout"]))
                 for name, info in truth["tracks"].items() if info["prefix"] == P for on, off in info["lives"]]
        counts = {k: [] for k in keys[:-1]}
        bad_rows = []
        problems = set()
        n_missing = 0
        for s, level, message, values in rows:
            missing = [k for k in keys if "%s: %s" % (P, k) not in values]
            if missing:
                n_missing += 1
                if n_missing == 1:
                    errors.append("%s at %.2f s: 'tracks' status without %s (has %s)"
                                  % (mon, s, ", ".join("'%s: %s'" % (P, k) for k in missing), sorted(values)))
                continue
            try:
                row = {k: int(float(values["%s: %s" % (P, k)])) for k in keys[:-1]}
            except ValueError:
                errors.append("%s at %.2f s: 'tracks' counts not numbers: %r" % (mon, s, values))
                continue
            for k in keys[:-1]:
                counts[k].append(row[k])
            problems.add(values["%s: %s" % (P, "last problem")])
            lo = sum(1 for on, off, _ in lives if on <= s - margin and off >= s + margin)
            hi = sum(1 for on, off, timeout in lives if on <= s + margin and off + timeout + margin >= s)
            if not lo <= row["objects"] <= hi:
                bad_rows.append((s, row["objects"], lo, hi))
            sources = len([t for t in truth.get("trackers", []) if t["in_node"]])
            m = re.search(r"(\d+) tracked objects? from (\d+) sources?", message)
            if not m or int(m.group(2)) != sources or (sources == 1 and int(m.group(1)) != row["objects"]):
                errors.append("%s at %.2f s: 'tracks' summary %r, expected \"%d tracked objects from %d source(s)\""
                              % (mon, s, message, row["objects"], sources))
        if n_missing > 1:
            errors.append("%s: %d of %d 'tracks' statuses without every '%s: ...' key" % (mon, n_missing, len(rows), P))
        for s, n, lo, hi in bad_rows[:5]:
            errors.append("%s at %.2f s: '%s: objects' is %d, the truth allows %d to %d (alive within %.2f s of the "
                          "stamp, or left less than the timeout + %.2f s before)" % (mon, s, P, n, lo, hi, margin, margin))
        if not counts["objects"] or max(counts["objects"]) <= 0:
            errors.append("%s: '%s: objects' never above 0 (%d statuses)" % (mon, P, len(rows)))
        if (tr["nan_objects"] or tr["nan_copies"]) and (not counts["objects dropped"] or max(counts["objects dropped"]) <= 0):
            errors.append("%s: '%s: objects dropped' never above 0, the tracker sent %d always-NaN object(s) and %d NaN "
                          "copies" % (mon, P, tr["nan_objects"], tr["nan_copies"]))
        for e in self.expect.get("tracks", []) or []:
            if e.get("prefix", P) != P or e.get("monitor", mon) != mon:
                continue
            for k, need in (e.get("min") or {}).items():
                k = k[len(P) + 2:] if k.startswith(P + ": ") else k
                got = max(counts.get(k) or [float("-inf")])
                if got < need:
                    errors.append("%s: '%s: %s' at most %s, expected at least %s" % (mon, P, k, got, need))
        mx = {k: (max(v) if v else None) for k, v in counts.items()}
        self.diag_summary.append(
            "  diagnostics tracks %s (%s): %d statuses, objects %s to %s (%d outside the truth's bounds), max objects "
            "dropped %s, expired %s, arrays accepted %s, dropped %s; last problems %s"
            % (P, mon, len(rows), min(counts["objects"]) if counts["objects"] else None, mx["objects"], len(bad_rows),
               mx["objects dropped"], mx["objects expired"], mx["arrays accepted"], mx["arrays dropped"],
               sorted(problems)[:3]))
        return errors

    def test_impacts(self):
        errors = []
        for m in self.monitors:
            errors.extend(self.check_monitor(m))
        self.assertFalse(errors, "\n" + "\n".join(errors[:40]) + ("\n... %d more" % (len(errors) - 40) if len(errors) > 40 else "")
                         + self.kept())

    # ------------------------------------------------------------------ diagnostics and survival
    def test_diagnostics_and_survival(self):
        errors = []
        t0 = 1000.0
        for m in self.monitors:
            if not self.record["alive_after_bag"].get(m):
                errors.append("%s was not running any more after the bag" % m)
        if self.record["rosbag_play_rc"] != 0:
            errors.append("rosbag play exited with status %d" % self.record["rosbag_play_rc"])
        diags = self.record["diagnostics"]
        bodies = {}
        for s, name, level, message, values in diags:
            if name.endswith(": bodies"):
                bodies.setdefault(name.split(":")[0].lstrip("/"), []).append((s - t0, level, message, values))
        for m in self.monitors:
            if not bodies.get(m):
                errors.append("%s: no 'bodies' status on /diagnostics" % m)
        tracks = {}
        for s, name, level, message, values in diags:
            if name.endswith(": tracks"):
                tracks.setdefault(name.split(":")[0].lstrip("/"), []).append((s - t0, level, message, values))
        for m in self.monitors:
            for tr in self.truths[m].get("trackers", []) or []:
                if tr["in_node"]:
                    errors.extend(self.check_track_diagnostics(m, tr, self.truths[m], tracks.get(m, []),
                                                               float(rospy.get_param("/%s/rate" % m))))
        # Temporal coherence on (~coherence_clearance > 0): certificates must have answered pairs
        # (the scenario's other checks then show that none hid an impact).
        for m in self.monitors:
            if float(rospy.get_param("/%s/coherence_clearance" % m, 0.0)) <= 0.0:
                continue
            key = "candidates answered by certificates in window"  # every cycle since the last status
            counts = [int(float(values[key])) for s, name, level, message, values in diags
                      if name.endswith(": cycle") and name.split(":")[0].lstrip("/") == m and key in values]
            if not counts or max(counts) == 0:
                errors.append("%s: coherence_clearance > 0 but no cycle status shows a pair answered by a certificate "
                              "(%d statuses)" % (m, len(counts)))
            else:
                self.diag_summary.append("  diagnostics cycle %s: %d candidate pairs answered by certificates in %d "
                                         "statuses (up to %d in one)" % (m, sum(counts), len(counts), max(counts)))
        for e in self.expect.get("diagnostics", []) or []:
            mon = e.get("monitor", self.monitors[0])
            lo, hi = e["during"]
            n_errors = len(errors)
            rows = [r for r in bodies.get(mon, []) if lo <= r[0] <= hi]
            if not rows:
                errors.append("%s: no 'bodies' diagnostics in [%.1f, %.1f] s" % (mon, lo, hi))
                continue
            for s, level, message, values in rows:
                v = values.get(e["body"])
                if v is None:
                    errors.append("%s at %.2f s: body %s missing from the diagnostics" % (mon, s, e["body"]))
                    continue
                for c in e.get("contains", []):
                    if c not in v:
                        errors.append("%s at %.2f s: %s: %r does not contain %r" % (mon, s, e["body"], v, c))
                if "level" in e and level != int(e["level"]):
                    errors.append("%s at %.2f s: bodies status level %d, expected %d (%s)" % (mon, s, level, e["level"], message))
                for c in e.get("summary_contains", []):
                    if c not in message:
                        errors.append("%s at %.2f s: summary %r does not contain %r" % (mon, s, message, c))
                for other in e.get("others_ok", []):
                    if values.get(other) != "ok":
                        errors.append("%s at %.2f s: %s is %r, expected 'ok'" % (mon, s, other, values.get(other)))
            self.diag_summary.append("  diagnostics [%.1f, %.1f] s, %s: %s (%d statuses), e.g. %r"
                                     % (lo, hi, e["body"], "as expected" if len(errors) == n_errors else "MISMATCH",
                                        len(rows), rows[len(rows) // 2][3].get(e["body"])))
        self.assertFalse(errors, "\n" + "\n".join(errors[:40]) + self.kept())


if __name__ == "__main__":
    rostest.rosrun("vadop", NAME, ScenarioCheck, sys.argv)
