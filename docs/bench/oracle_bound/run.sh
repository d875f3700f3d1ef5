#!/bin/bash
# What any broad phase could gain on the monitor's workload: the cycle with a broad phase that
# cost nothing and handed the narrow phase exactly the pairs that collide. Needs a build of
# vadop_monitor_bench with instrument.patch applied (World::predict's CPU cycles, and the
# narrow phase's per pair, split by whether the pair collides; printed at exit), e.g.
#   git worktree add /tmp/wt_oracle HEAD && git -C /tmp/wt_oracle apply "$PWD/instrument.patch"
#   (configure /tmp/wt_oracle as in README "Building by hand", Release; make vadop_monitor_bench)
# usage: bash run.sh BENCH ROUNDS   (one CSV line per run; summarise.py turns them into the bound)
bench=$1; rounds=${2:-3}
echo "round,bodies,broad_phase,time_slices,wall_med_ms,predict_ms,candidates,impacts,predict_tsc,hit_tsc,hit_pairs,miss_tsc,miss_pairs"
for r in $(seq 1 "$rounds"); do
  for n in 1000 5000; do
    configs="grid:8 vadop:8 grid:1 vadop:1"
    [ $((r % 2)) = 0 ] && configs="vadop:1 grid:1 vadop:8 grid:8"
    for c in $configs; do
      bp=${c%:*}; ts=${c#*:}
      "$bench" --bodies "$n" --cycles 60 --warmup 5 --threads 1 --broadphase "$bp" --time-slices "$ts" 2>&1 |
        awk -v r="$r" -v bp="$bp" -v ts="$ts" '
          NF >= 14 && $1 ~ /^[0-9]+$/ && $2 ~ /^[0-9.]+$/ {row = r "," $1 "," bp "," ts "," $5 "," $9 "," $12 "," $13}
          /^PROF/ {prof = $3 "," $7 "," substr($8, 2) "," $11 "," substr($12, 2)}
          END {print row "," prof}'
    done
  done
done
