#!/usr/bin/python3
"""Starts vadop_monitor on a scenario file's monitor parameters (test/scenario.test).

A scenario file (test/scenarios/*.yaml) holds the monitor's parameters at its top level and the
motion script under `scenario:`, which the monitor does not know (an unknown key stops it). This
node sets the file's keys except `scenario` in its own private namespace, leaving those the
launch file already set there (a padded twin's `padding`), then becomes vadop_monitor with the
same arguments (name, remappings), so the monitor reads them as its own.

Parameter: ~scenario_file (path of the yaml).
"""
import os
import sys

import rosgraph
import rosgraph.names
import roslib.packages
import yaml


def private_namespace():
    """The node's name as roslaunch gives it (__name:=, ROS_NAMESPACE / __ns:=)."""
    name, ns = None, rosgraph.names.get_ros_namespace()
    for arg in sys.argv[1:]:
        if arg.startswith("__name:="):
            name = arg[len("__name:="):]
        elif arg.startswith("__ns:="):
            ns = rosgraph.names.make_global_ns(arg[len("__ns:="):])
    if not name:
        sys.exit("scenario_monitor.py: no __name:= argument (start it from a launch file)")
    return rosgraph.names.ns_join(ns, name)


def main():
    node = private_namespace()
    master = rosgraph.Master(node)
    with open(master.getParam(node + "/scenario_file")) as f:
        params = yaml.safe_load(f)
    params.pop("scenario", None)
    for key, value in params.items():
        if not master.hasParam(node + "/" + key):
            master.setParam(node + "/" + key, value)
    master.deleteParam(node + "/scenario_file")
    monitor = roslib.packages.find_node("vadop", "vadop_monitor")
    if not monitor:
        sys.exit("scenario_monitor.py: vadop_monitor not found")
    os.execv(monitor[0], [monitor[0]] + sys.argv[1:])


if __name__ == "__main__":
    main()
