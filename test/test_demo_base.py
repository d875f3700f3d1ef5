#!/usr/bin/python3
"""demo_sim.py's simulated base (Base) without ROS transport: a command executes `delay` after
its arrival, the velocity ramps at the base's rates, and a command older than cmd_timeout is
dropped for zero (the base stops by itself when its gate falls silent)."""
import os
import sys
import unittest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "vadop_ros", "nodes"))
from demo_sim import Base  # noqa: E402


def run(base, t0, t1, dt=0.01):
    """Advances the base from t0 to t1; returns [(t, v)] at each step's end."""
    out = []
    t = t0
    while t < t1 - 1e-9:
        t += dt
        v, _ = base.advance(t, dt)
        out.append((t, v))
    return out


class DemoBaseTest(unittest.TestCase):
    def test_delay_ramp_and_command_timeout(self):
        base = Base(delay=0.06, lin_acc=1.0, ang_acc=2.0, cmd_timeout=0.5)
        base.command(0.0, 0.3, 0.0)
        trace = run(base, 0.0, 2.0)
        at = dict((round(t, 2), v) for t, v in trace)
        # Nothing before the delay; then up at 1 m/s^2 to 0.3 m/s (from 0.06 s to 0.36 s).
        self.assertEqual(max(v for t, v in trace if t <= 0.05 + 1e-9), 0.0)
        self.assertAlmostEqual(at[0.5], 0.3, places=9)
        # The command took effect at 0.06 s: dropped 0.5 s later, then down at 1 m/s^2 (0.3 s).
        self.assertAlmostEqual(at[0.55], 0.3, places=9)
        self.assertAlmostEqual(at[0.7], 0.3 - 0.15, delta=0.01)
        self.assertEqual(trace[-1][1], 0.0)
        stopped = min(t for t, v in trace if t > 0.56 and v == 0.0)
        self.assertAlmostEqual(stopped, 0.86, delta=0.015)

    def test_fresh_commands_keep_it_going(self):
        base = Base(delay=0.06, lin_acc=1.0, ang_acc=2.0, cmd_timeout=0.5)
        trace = []
        for k in range(20):  # a command every 0.1 s for 2 s
            base.command(0.1 * k, 0.5, 0.0)
            trace += run(base, 0.1 * k, 0.1 * (k + 1))
        self.assertAlmostEqual(trace[-1][1], 0.5, places=6)


if __name__ == "__main__":
    if any(a.startswith("--gtest_output") for a in sys.argv):  # run by catkin: junit result file
        import rosunit
        rosunit.unitrun("vadop", "test_demo_base", DemoBaseTest, sys.argv)
    else:
        unittest.main()
