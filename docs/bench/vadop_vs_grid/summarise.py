#!/usr/bin/env python3
"""Medians and per-round ratios of docs/bench/one_thread.sh's output (H = the first bench, N =
the second): CPU ms of a cycle per workload and fleet size, and the candidates of each.
usage: python3 summarise.py runs.txt"""
import re
import statistics as st
import sys

rows = {}
for line in open(sys.argv[1]):
    m = re.match(r"(\d+) ([HN]) (.*?) ?(\d+ [\d.]+ [\d.]+ [\d.]+ [\d.]+ \|.*)", line)
    if not m:
        continue
    rnd, build, workload = m.group(1), m.group(2), m.group(3) or "planar"
    for cell in m.group(4).split("|"):
        c = cell.split()
        if c:
            rows.setdefault((workload, int(c[0])), {}).setdefault(build, {})[rnd] = (float(c[1]), float(c[3]), float(c[4]))
for (workload, n), d in sorted(rows.items()):
    ratios = [d["N"][r][0] / d["H"][r][0] for r in sorted(d["H"]) if r in d["N"]]
    print("%-11s %6d  H %7.2f ms  N %7.2f ms  N/H median %.2f (%.2f-%.2f, %d rounds)  candidates %.1f / %.1f  impacts %.1f / %.1f"
          % (workload, n, st.median(v[0] for v in d["H"].values()), st.median(v[0] for v in d["N"].values()),
             st.median(ratios), min(ratios), max(ratios), len(ratios), d["H"]["1"][1], d["N"]["1"][1],
             d["H"]["1"][2], d["N"]["1"][2]))
