# Medians (ranges) of run_paper_scene.sh's rows (docs/bench/parallel_broad_phase/), new/old per
# round, the response cost c_r and the plain grid against VADOP within each build.
# Usage: python3 summarize_paper_scene.py paper_scene.txt
import collections, statistics, sys

rows = collections.defaultdict(dict)  # (method, speed) -> {(round, build): (frame, c_r, missed, cand)}
for line in open(sys.argv[1]):
    f = line.split()
    if len(f) < 17:
        continue
    # round build method n speed m phi frame_ms p95_ms c_u c_s c_t c_r cand/frame impacts missed rss_MB
    rows[(f[2], f[4])][(f[0], f[1])] = (float(f[7]), float(f[12]), f[15], f[13])


def med(xs):
    return f"{statistics.median(xs):.1f} ({min(xs):.1f}-{max(xs):.1f})"


for (method, speed), v in sorted(rows.items()):
    rounds = sorted({k[0] for k in v})
    got = {b: [v[(r, b)] for r in rounds if (r, b) in v] for b in ("old", "new")}
    ratio = [v[(r, "new")][0] / v[(r, "old")][0] for r in rounds if (r, "new") in v and (r, "old") in v]
    print(f"{method:5} speed {speed:>4}: frame ms old {med([x[0] for x in got['old']])} new {med([x[0] for x in got['new']])}"
          f" new/old {' / '.join(f'{x:.2f}' for x in ratio)}; c_r old {med([x[1] for x in got['old']])}"
          f" new {med([x[1] for x in got['new']])}; missed {sorted({x[2] for x in v.values()})}"
          f" candidates {sorted({x[3] for x in v.values()})}")
for speed in sorted({s for _, s in rows}, key=float):
    for build in ("old", "new"):
        r = [rows[("vadop", speed)][k][0] / rows[("grid", speed)][k][0] for k in rows[("vadop", speed)]
             if k[1] == build and k in rows[("grid", speed)]]
        print(f"VADOP / grid, speed {speed}, {build}: " + " / ".join(f"{x:.2f}" for x in r))
