# Interleaved comparison of two vadop_monitor_bench builds on one thread, the order swapped
# every round.
# usage: bash one_thread.sh BASE_BENCH NEW_BENCH ROUNDS SIZES WORKLOAD...
#   SIZES: the fleet sizes (--bodies), e.g. 1000,5000,10000; each WORKLOAD one string of the
#   bench's options ("" for its default planar fleet), e.g. "--links 3 --joints".
# Each line: round, build (H = base, N = new), the workload, then per fleet size: bodies, CPU
# ms mean, wall ms median, candidates, impacts (30 cycles after 3).
H=$1
N=$2
rounds=$3
sizes=$4
shift 4
row() { awk '/^ +[0-9]+ +[0-9.]+ /{printf "%s %s %s %s %s | ", $1, $2, $5, $12, $13}'; }
for r in $(seq "$rounds"); do
  if [ $((r % 2)) = 1 ]; then order="H N"; else order="N H"; fi
  for w in "$@"; do
    for which in $order; do
      B=$H
      [ "$which" = N ] && B=$N
      # shellcheck disable=SC2086
      echo "$r $which $w $("$B" --bodies "$sizes" $w --threads 1 --cycles 30 --warmup 3 2>&1 | row)"
    done
  done
done
