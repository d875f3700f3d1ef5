# Interleaved comparison of two vadop_monitor_bench builds on one thread: the planar fleets of
# 1,000, 5,000 and 10,000 robots, 30 cycles after 3, 4 rounds, the order swapped every round;
# then 1,000 bodies of four other workloads, 2 rounds.
# usage: bash run_one_thread.sh BASE_BENCH NEW_BENCH > one_thread.txt
# Each line: round, build (H = base, N = new), then per fleet size: bodies, CPU ms mean, wall ms
# median, candidates, impacts.
H=$1
N=$2
row() { awk '/^ +[0-9]+ +[0-9.]+ /{printf "%s %s %s %s %s | ", $1, $2, $5, $12, $13}'; }
for r in 1 2 3 4; do
  if [ $((r % 2)) = 1 ]; then order="H N"; else order="N H"; fi
  for which in $order; do
    B=$H
    [ "$which" = N ] && B=$N
    echo "$r $which $("$B" --bodies 1000,5000,10000 --threads 1 --cycles 30 --warmup 3 2>&1 | row)"
  done
done
for r in 1 2; do
  for w in "--3d 10" "--fast 0.1" "--links 2" "--area 25"; do
    for which in H N; do
      B=$H
      [ "$which" = N ] && B=$N
      # shellcheck disable=SC2086
      echo "$r $which $w $("$B" --bodies 1000 $w --threads 1 --cycles 30 --warmup 3 2>&1 | row)"
    done
  done
done
