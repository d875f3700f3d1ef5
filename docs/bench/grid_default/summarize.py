# Medians (ranges) of run.sh's rows per build and broad phase, and ratios per round: the new
# build's grid (the node's default) against the base build's vadop (its default before 49ffc57),
# each broad phase of the new build against the base build's, and vadop / grid in the new build.
# Usage: python3 summarize.py monitor.csv  (CPU mean of the cycle thread for --threads 1, else
# the wall median per cycle).
import collections, statistics, sys

rows = collections.defaultdict(dict)  # (args, bodies) -> {(round, build, bp): value}
for line in open(sys.argv[1]):
    parts = line.strip().split(",", 3)
    if len(parts) < 4 or "," not in parts[3]:
        continue
    rnd, build, bp = parts[:3]
    args, data = parts[3].rsplit(",", 1)  # the arguments may hold commas (--bodies 5000,10000)
    data = data.split()
    if not data or not data[0].isdigit():
        continue
    value = float(data[1]) if "--threads 1" in args else float(data[4])
    rows[(args, data[0])][(rnd, build, bp)] = (value, data[11])


def show(v, key):
    xs = [x for k, (x, _) in v.items() if k[1:] == key]
    return f"{statistics.median(xs):.1f} ({min(xs):.1f}-{max(xs):.1f})" if xs else "-"


def ratio(v, num, den):
    rounds = sorted({k[0] for k in v})
    return " / ".join(f"{v[(r, *num)][0] / v[(r, *den)][0]:.2f}" for r in rounds
                      if (r, *num) in v and (r, *den) in v)


for (args, bodies), v in rows.items():
    label = args.replace("--cycles 100 --warmup 15", "").replace("--cycles 60 --warmup 10", "").strip()
    cands = {k[2]: c for k, (_, c) in v.items()}
    print(f"{label} [{bodies}] candidates grid {cands.get('grid')} vadop {cands.get('vadop')}")
    for key in [("base", "vadop"), ("base", "grid"), ("new", "vadop"), ("new", "grid")]:
        print(f"  {key[0]:4} {key[1]:5} {show(v, key)}")
    print(f"  new grid / base vadop: {ratio(v, ('new', 'grid'), ('base', 'vadop'))}")
    print(f"  new build / base build: vadop {ratio(v, ('new', 'vadop'), ('base', 'vadop'))}, "
          f"grid {ratio(v, ('new', 'grid'), ('base', 'grid'))}")
    print(f"  vadop / grid in the new build: {ratio(v, ('new', 'vadop'), ('new', 'grid'))}")
