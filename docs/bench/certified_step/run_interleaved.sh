#!/bin/bash
# A/B of vadop_monitor_bench: the build of the old commit (BB) against this one (B), interleaved.
export PATH=/usr/bin:$PATH
B=/work/b/ros/devel/lib/vadop/vadop_monitor_bench; BB=/work/b/rosh/devel/lib/vadop/vadop_monitor_bench
rounds=${ROUNDS:-4}
out=/tmp/abmon.csv
: > $out
run() { # tag build args...
  local tag=$1 build=$2; shift 2
  $build "$@" 2>&1 | grep -E "^ +[0-9]+ " | while read -r line; do echo "$tag,$*,$line" | tr -s ' ' >> $out; done
}
for r in $(seq 1 $rounds); do
  for cfg in "--bodies 1000 --threads 1 --cycles 100 --warmup 15" "--bodies 1000 --threads 1 --cycles 100 --warmup 15 --links 2" "--bodies 1000 --threads 1 --cycles 100 --warmup 15 --3d 10" "--bodies 1000 --threads 1 --cycles 100 --warmup 15 --fast 0.1" "--bodies 5000,10000 --threads 0 --cycles 60 --warmup 10"; do
    if [ $((r % 2)) = 1 ]; then run "r$r,new" $B $cfg; run "r$r,base" $BB $cfg
    else run "r$r,base" $BB $cfg; run "r$r,new" $B $cfg; fi
  done
done
echo finished >> $out
