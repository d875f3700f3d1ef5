#!/bin/bash
# Interleaved wall-clock comparison of two vadop_monitor_bench builds, both cores.
# usage: run.sh BASE_BENCH NEW_BENCH ROUNDS  (prints one CSV line per run)
base=$1; new=$2; rounds=${3:-4}
echo "round,build,bodies,wall_med_ms,wall_mean_ms,candidates,impacts"
for r in $(seq 1 "$rounds"); do
  if [ $((r % 2)) = 1 ]; then order="base new"; else order="new base"; fi
  for bodies in 10000 5000; do
    for b in $order; do
      exe=$base; [ "$b" = new ] && exe=$new
      "$exe" --bodies "$bodies" --cycles 90 --warmup 5 --threads 0 2>/dev/null |
        awk -v r="$r" -v b="$b" 'NF >= 14 && $1 ~ /^[0-9]+$/ && $2 ~ /^[0-9.]+$/ {print r "," b "," $1 "," $5 "," $4 "," $12 "," $13}'
    done
  done
done
