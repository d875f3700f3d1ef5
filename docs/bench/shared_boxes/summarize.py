#!/usr/bin/env python3
"""Medians, ranges and per-round new/base ratios of run.sh / run_workloads.sh CSVs."""
import csv, statistics, sys
from collections import defaultdict
for path in sys.argv[1:]:
    rows = list(csv.DictReader(open(path)))
    key = 'workload' if 'workload' in rows[0] else 'bodies'
    col = 'cpu_mean_ms' if 'cpu_mean_ms' in rows[0] else 'wall_med_ms'
    cols = [col] + (['wall_med_ms'] if col == 'cpu_mean_ms' else [])
    for c in cols:
        by = defaultdict(lambda: defaultdict(dict))
        same = True
        for r in rows:
            by[r[key]][r['build']][r['round']] = float(r[c])
        cand = defaultdict(set)
        for r in rows:
            cand[r[key]].add((r['candidates'], r['impacts']))
        print(f"{path}: {c}")
        for w, b in by.items():
            rounds = sorted(b['base'])
            ratios = [b['new'][k] / b['base'][k] for k in rounds]
            def fmt(v):
                v = list(v)
                return f"{statistics.median(v):.1f} ({min(v):.1f}-{max(v):.1f})"
            print(f"  {w}: base {fmt(b['base'].values())}  new {fmt(b['new'].values())}  new/base "
                  + " / ".join(f"{x:.2f}" for x in ratios)
                  + ("" if len(cand[w]) == 1 else "  CANDIDATES OR IMPACTS DIFFER"))
