# Temporal coherence on the monitor's workloads: each row's per-cycle CPU ratio (coherence on /
# off, the same messages, which core runs first alternating) from vadop_monitor_bench --paired,
# ROUNDS times. Usage: bash run.sh BENCH [ROUNDS] > runs.txt
set -eu
BENCH=$1
ROUNDS=${2:-3}
rows=(
  "planar 0|--bodies 1000 --noise 0"
  "planar 0.01|--bodies 1000 --noise 0.01"
  "planar 0.02|--bodies 1000 --noise 0.02"
  "planar 0.05|--bodies 1000 --noise 0.05"
  "links2 0.01|--bodies 1000 --links 2 --noise 0.01"
  "3d 0.01|--bodies 1000 --3d 10 --noise 0.01"
  "fast 0.01|--bodies 1000 --fast 0.1 --noise 0.01"
  "planar5000 0.01|--bodies 5000 --noise 0.01"
)
for round in $(seq "$ROUNDS"); do
  for row in "${rows[@]}"; do
    name=${row%%|*}
    args=${row#*|}
    # shellcheck disable=SC2086
    out=$("$BENCH" $args --threads 1 --cycles 150 --coherence 0.2,0.5 --paired 2>&1)
    cand=$(echo "$out" | awk '/^ bodies/ {getline; print $12}')
    reused=$(echo "$out" | sed -n 's/.*candidate pairs, \([0-9.]*\) per cycle answered.*/\1/p')
    ratio=$(echo "$out" | sed -n 's/.*per-cycle ratio median \([0-9.]*\) (quartiles \([0-9.]*-[0-9.]*\)).*/\1 \2/p')
    echo "$round $name candidates $cand reused $reused ratio $ratio"
  done
done
