#!/usr/bin/env python3
"""The table of run.sh's output: per workload, one thread (CPU ms a cycle, the mean of each run)
and both cores (wall ms a cycle, the median and the 95th percentile of each run): median (min-max) over the rounds, and
the candidates past the cull and impacts a cycle (the same in every run of a workload).
usage: python3 summarise.py runs.txt"""
import re
import statistics as st
import sys

runs = {}
order = []
for line in open(sys.argv[1]):
    m = re.match(r"(\d+) ([01]) (.*?) \| +(\S.*)", line)
    if not m:
        continue
    _, threads, workload, row = m.groups()
    c = row.split()
    if workload not in runs:
        order.append(workload)
    runs.setdefault(workload, {}).setdefault(threads, []).append(
        (float(c[1]), float(c[4]), float(c[11]), float(c[12]), float(c[5])))


def cell(values):
    return "%.1f (%.1f-%.1f)" % (st.median(values), min(values), max(values))


print("| workload (`vadop_monitor_bench`) | one thread, CPU | both cores, wall | both cores, wall p95 | rounds | candidates | impacts |")
print("|---|---|---|---|---|---|---|")
for w in order:
    one = [r[0] for r in runs[w].get("1", [])]
    both = [r[1] for r in runs[w].get("0", [])]
    p95 = [r[4] for r in runs[w].get("0", [])]
    first = (runs[w].get("0") or runs[w]["1"])[0]
    print("| `%s` | %s | %s | %s | %d | %.0f | %.0f |" % (w, cell(one), cell(both), cell(p95), len(both), first[2],
                                                     first[3]))
