#!/bin/bash
# Interleaved wall-clock comparison of two vadop_monitor_bench builds on fleets of mobile
# manipulators (--links K --joints: a base and a K-1-link arm on revolute joints, its links
# predicted along the joints' motion), both cores.
# usage: run.sh BASE_BENCH NEW_BENCH ROUNDS  (prints one CSV line per run)
base=$1; new=$2; rounds=${3:-3}
echo "round,build,workload,bodies,wall_med_ms,wall_mean_ms,candidates,impacts"
for r in $(seq 1 "$rounds"); do
  if [ $((r % 2)) = 1 ]; then order="base new"; else order="new base"; fi
  for w in "3 100" "3 300" "3 1000" "4 300"; do
    set -- $w
    for b in $order; do
      exe=$base; [ "$b" = new ] && exe=$new
      "$exe" --bodies "$2" --links "$1" --joints --cycles 20 --warmup 3 --threads 0 2>/dev/null |
        awk -v r="$r" -v b="$b" -v k="links$1" 'NF >= 14 && $1 ~ /^[0-9]+$/ && $2 ~ /^[0-9.]+$/ {print r "," b "," k "," $1 "," $5 "," $4 "," $12 "," $13}'
    done
  done
done
