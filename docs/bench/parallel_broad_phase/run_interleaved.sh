#!/bin/bash
# A/B of vadop_monitor_bench: a build of the commit before (BB, its own binary and libraries)
# against this one (B), interleaved, the order swapped each round. Rows into $out as
# round,build,arguments,<the bench's row>.
export PATH=/usr/bin:$PATH
B=${B:-/work/b/ros/devel/lib/vadop/vadop_monitor_bench}
BB=${BB:-/work/b/rosh/devel/lib/vadop/vadop_monitor_bench}
rounds=${ROUNDS:-3}
out=${OUT:-/tmp/parallel_bp.csv}
: > "$out"
run() { # tag build args...
  local tag=$1 build=$2; shift 2
  "$build" "$@" 2>&1 | grep -E "^ +[0-9]+ " | while read -r line; do echo "$tag,$*,$line" | tr -s ' ' >> "$out"; done
}
for r in $(seq 1 "$rounds"); do
  for cfg in "--bodies 1000 --threads 1 --cycles 100 --warmup 15" \
             "--bodies 1000 --threads 0 --cycles 100 --warmup 15" \
             "--bodies 1000 --threads 0 --cycles 100 --warmup 15 --links 2" \
             "--bodies 1000 --threads 0 --cycles 100 --warmup 15 --fast 0.1" \
             "--bodies 5000,10000 --threads 0 --cycles 60 --warmup 10"; do
    if [ $((r % 2)) = 1 ]; then run "r$r,new" "$B" $cfg; run "r$r,base" "$BB" $cfg
    else run "r$r,base" "$BB" $cfg; run "r$r,new" "$B" $cfg; fi
  done
done
echo finished >> "$out"
