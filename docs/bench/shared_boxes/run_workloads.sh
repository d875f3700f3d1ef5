#!/bin/bash
# The monitor's other workloads, two builds interleaved (the order swapped each round).
# usage: run_workloads.sh BASE_BENCH NEW_BENCH ROUNDS  (one CSV line per run)
base=$1; new=$2; rounds=${3:-3}
workloads=("--bodies 1000 --threads 1" "--bodies 1000 --threads 0" "--bodies 1000 --links 2 --threads 0"
           "--bodies 1000 --fast 0.1 --threads 0" "--bodies 1000 --3d 10 --threads 0")
echo "round,build,workload,cpu_mean_ms,wall_med_ms,candidates,impacts"
for r in $(seq 1 "$rounds"); do
  if [ $((r % 2)) = 1 ]; then order="base new"; else order="new base"; fi
  for w in "${workloads[@]}"; do
    for b in $order; do
      exe=$base; [ "$b" = new ] && exe=$new
      # shellcheck disable=SC2086
      "$exe" $w 2>/dev/null |
        awk -v r="$r" -v b="$b" -v w="$w" 'NF >= 14 && $1 ~ /^[0-9]+$/ && $2 ~ /^[0-9.]+$/ {print r "," b ",\"" w "\"," $2 "," $5 "," $12 "," $13}'
    done
  done
done
