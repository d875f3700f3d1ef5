# Interleaved comparison of two vadop_monitor_bench builds on the node's workloads, both cores
# (--threads 0), 40 cycles after 5, 3 rounds, the order swapped in round 2.
# usage: bash run.sh BASE_BENCH NEW_BENCH > runs.txt
# Each line: round, build (O = base, N = new), the workload's options | the bench's result row
# (bodies cpu_mean cpu_p95 wall_mean wall_med ... candidates impacts culled registry).
O=$1
N=$2
for r in 1 2 3; do
  if [ "$r" = 2 ]; then order="N O"; else order="O N"; fi
  for w in "--bodies 1000" "--bodies 5000" "--bodies 10000" "--bodies 300 --links 3 --joints" \
           "--bodies 1000 --links 3 --joints" "--bodies 300 --links 4 --joints"; do
    for which in $order; do
      B=$O
      [ "$which" = N ] && B=$N
      # shellcheck disable=SC2086
      line=$("$B" $w --threads 0 --cycles 40 --warmup 5 2>&1 | awk '/^ bodies/{getline; print}')
      echo "$r $which $w | $line"
    done
  done
done
