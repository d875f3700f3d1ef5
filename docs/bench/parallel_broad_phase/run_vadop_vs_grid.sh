#!/bin/bash
# VADOP against the plain grid in the same build (same narrow phase and cull), 3 rounds, the
# order swapped each round: one thread (CPU ms of the cycle) and both cores (wall ms).
export PATH=/usr/bin:$PATH
B=${B:-/work/b/ros/devel/lib/vadop/vadop_monitor_bench}
out=${OUT:-/tmp/vadop_vs_grid.csv}; : > "$out"
for r in 1 2 3; do
  for cfg in "--bodies 1000 --threads 1 --cycles 100 --warmup 15" "--bodies 5000 --threads 1 --cycles 40 --warmup 10" \
             "--bodies 5000,10000 --threads 0 --cycles 40 --warmup 10"; do
    if [ $((r % 2)) = 1 ]; then order="vadop grid"; else order="grid vadop"; fi
    for bp in $order; do
      "$B" $cfg --broadphase $bp 2>&1 | grep -E "^ +[0-9]+ +[0-9.]+ " | while read -r line; do echo "r$r|$bp|$cfg|$line" >> "$out"; done
    done
  done
done
echo finished >> "$out"
