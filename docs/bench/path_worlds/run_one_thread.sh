# Interleaved comparison of two vadop_monitor_bench builds on one thread: fleets of 300 and
# 1,000 mobile manipulators with 2-link and 3-link arms on moving joints, 30 cycles after 3,
# 4 rounds, the order swapped every round.
# usage: bash run_one_thread.sh BASE_BENCH NEW_BENCH > one_thread.txt
# Each line: round, build (H = base, N = new), the workload, then per fleet size: bodies, CPU
# ms mean, wall ms median, candidates, impacts.
H=$1
N=$2
row() { awk '/^ +[0-9]+ +[0-9.]+ /{printf "%s %s %s %s %s | ", $1, $2, $5, $12, $13}'; }
for r in 1 2 3 4; do
  if [ $((r % 2)) = 1 ]; then order="H N"; else order="N H"; fi
  for w in "--links 3 --joints" "--links 4 --joints"; do
    for which in $order; do
      B=$H
      [ "$which" = N ] && B=$N
      # shellcheck disable=SC2086
      echo "$r $which $w $("$B" --bodies 300,1000 $w --threads 1 --cycles 30 --warmup 3 2>&1 | row)"
    done
  done
done
