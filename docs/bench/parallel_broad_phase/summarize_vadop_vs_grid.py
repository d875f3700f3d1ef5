# VADOP / grid per round from run_vadop_vs_grid.sh's rows (round|engine|arguments|bench row):
# CPU mean with --threads 1, wall median otherwise; candidates beside.
import collections, sys

rows = collections.defaultdict(dict)
for line in open(sys.argv[1]):
    parts = line.strip().split("|")
    if len(parts) != 4:
        continue
    rnd, engine, args, data = parts
    d = data.split()
    value = float(d[1]) if "--threads 1" in args else float(d[4])
    rows[(args, d[0])][(rnd, engine)] = (value, float(d[11]))
for (args, bodies), v in rows.items():
    rounds = sorted({r for r, _ in v})
    ratios = [v[(r, "vadop")][0] / v[(r, "grid")][0] for r in rounds if (r, "vadop") in v and (r, "grid") in v]
    label = "one thread, CPU" if "--threads 1" in args else "both cores, wall"
    print(f"{bodies} bodies, {label}: VADOP / grid " + " / ".join(f"{x:.2f}" for x in ratios) +
          f"; candidates {v[(rounds[0], 'vadop')][1]:.0f} / {v[(rounds[0], 'grid')][1]:.0f}")
