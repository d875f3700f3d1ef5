#!/usr/bin/env python3
"""The oracle bound from run.sh's CSV. Per run, the cycle a broad phase could reach if it cost
nothing and handed the narrow phase exactly the pairs that collide (no cull needed either):
(wall - predict) + predict * hit / total, the part of World::predict spent on the narrow phase
of colliding pairs being hit / total of its CPU cycles. Ratios against the plain grid's cycle of
the same round, with the cull (time_slices 8, the node's default) and without it (1).
Medians and ranges over the rounds."""
import csv
import statistics
import sys
from collections import defaultdict

runs = defaultdict(dict)
for r in csv.DictReader(open(sys.argv[1])):
    runs[(r["round"], int(r["bodies"]))][(r["broad_phase"], int(r["time_slices"]))] = r

def wall(r):
    return float(r["wall_med_ms"])

def oracle(r):
    pred = float(r["predict_ms"])
    return (wall(r) - pred) + pred * float(r["hit_tsc"]) / float(r["predict_tsc"])

rows = defaultdict(list)
for (_, n), by in runs.items():
    g8, g1 = by[("grid", 8)], by[("grid", 1)]
    for (bp, ts), r in sorted(by.items()):
        name = "%s, time_slices %d" % (bp, ts)
        rows[(n, name, "cycle ms")].append(wall(r))
        rows[(n, name, "candidates")].append(float(r["candidates"]))
        rows[(n, name, "/ grid ts 8")].append(wall(r) / wall(g8))
        rows[(n, name, "/ grid ts 1")].append(wall(r) / wall(g1))
    rows[(n, "oracle", "cycle ms")].append(oracle(g8))
    rows[(n, "oracle", "candidates")].append(float(g8["impacts"]))
    rows[(n, "oracle", "/ grid ts 8")].append(oracle(g8) / wall(g8))
    rows[(n, "oracle", "/ grid ts 1")].append(oracle(g8) / wall(g1))

def cell(v, digits):
    return "%.*f (%.*f-%.*f)" % (digits, statistics.median(v), digits, min(v), digits, max(v))

print("| bodies | pipeline | cycle ms | candidates | / grid, cull (ts 8) | / grid, no cull (ts 1) |")
print("|---|---|---|---|---|---|")
for n in sorted({k[0] for k in rows}):
    for name in ("grid, time_slices 8", "vadop, time_slices 8", "grid, time_slices 1", "vadop, time_slices 1", "oracle"):
        v = lambda col: rows[(n, name, col)]
        print("| %d | %s | %s | %.0f | %s | %s |" % (n, name, cell(v("cycle ms"), 2), statistics.median(v("candidates")),
                                                  cell(v("/ grid ts 8"), 2), cell(v("/ grid ts 1"), 2)))
print("\n%d rounds, medians (range); one thread; the oracle's candidates are the colliding pairs."
      % len({k[0] for k in runs}))
