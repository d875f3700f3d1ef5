#!/bin/bash
# Two builds of vadop_monitor_bench (B: the change, BB: a base commit's) with both broad phases,
# the four runs of each workload in an order rotated each round. Rows into $OUT as
# round,build,broad_phase,arguments,<the bench's row>. Used for docs/bench/grid_default (BB =
# 89a7a11) and docs/bench/part_boxes (BB = 49ffc57).
export PATH=/usr/bin:$PATH
B=${B:-/work/b/ros/devel/lib/vadop/vadop_monitor_bench}
BB=${BB:-/work/b/basehead/devel/lib/vadop/vadop_monitor_bench}
rounds=${ROUNDS:-3}
out=${OUT:-/tmp/grid_default.csv}
: > "$out"
run() { # round build-tag binary broad-phase args...
  local r=$1 tag=$2 bin=$3 bp=$4; shift 4
  "$bin" "$@" --broadphase "$bp" 2>&1 | grep -E "^ +[0-9]+ +[0-9.]+ " |
    while read -r line; do echo "$r,$tag,$bp,$*,$line" | tr -s ' ' >> "$out"; done
}
variants=("new $B grid" "base $BB vadop" "new $B vadop" "base $BB grid")
for r in $(seq 1 "$rounds"); do
  for cfg in "--bodies 1000 --threads 1 --cycles 100 --warmup 15" \
             "--bodies 1000 --threads 0 --cycles 100 --warmup 15" \
             "--bodies 1000 --threads 0 --cycles 100 --warmup 15 --links 2" \
             "--bodies 1000 --threads 0 --cycles 100 --warmup 15 --fast 0.1" \
             "--bodies 5000,10000 --threads 0 --cycles 60 --warmup 10"; do
    for k in 0 1 2 3; do
      read -r tag bin bp <<< "${variants[$(( (k + r - 1) % 4 ))]}"
      run "r$r" "$tag" "$bin" "$bp" $cfg
    done
  done
done
echo finished >> "$out"
