# Medians (ranges) of the interleaved runs of run_interleaved.sh, and new/base per round.
# Usage: python3 summarize.py /tmp/parallel_bp.csv  (wall median per cycle for threads 0 runs,
# CPU mean of the cycle thread for --threads 1).
import collections, statistics, sys

rows = collections.defaultdict(dict)  # (args, bodies) -> {(round, build): value}
for line in open(sys.argv[1]):
    if "m^2" in line or "Hz" in line or line.count(",") < 3:
        continue
    rnd, build, rest = line.strip().split(",", 2)
    args, data = rest.rsplit(",", 1)
    data = data.split()
    if not data or not data[0].isdigit():
        continue
    bodies = data[0]
    value = float(data[1]) if "--threads 1" in args else float(data[4])  # cpu_mean or wall_med
    rows[(args, bodies)][(rnd, build)] = value
for (args, bodies), v in rows.items():
    rounds = sorted({r for r, _ in v})
    new = [v[(r, "new")] for r in rounds if (r, "new") in v]
    base = [v[(r, "base")] for r in rounds if (r, "base") in v]
    ratio = [v[(r, "new")] / v[(r, "base")] for r in rounds if (r, "new") in v and (r, "base") in v]
    label = args.replace("--cycles 100 --warmup 15", "").replace("--cycles 60 --warmup 10", "").strip()
    print(f"{label} [{bodies}]: base {statistics.median(base):.1f} ({min(base):.1f}-{max(base):.1f}) "
          f"new {statistics.median(new):.1f} ({min(new):.1f}-{max(new):.1f}) new/base "
          + " / ".join(f"{x:.2f}" for x in ratio))
