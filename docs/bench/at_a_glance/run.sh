# The README's "Cycle time at a glance": vadop_monitor_bench's workloads at one build, ROUNDS
# rounds spread over time (the workloads in reverse order every second round), on one thread
# (CPU ms a cycle) and on both cores (wall ms a cycle), 40 cycles after 5 warm-up.
# usage: bash run.sh BENCH ROUNDS > runs.txt; python3 summarise.py runs.txt
# Each line: round, threads (1 or 0 = all cores), the workload's options | the bench's result
# row (bodies cpu_mean cpu_p95 wall_mean wall_med wall_p95 wall_max feed predict markers cpu%
# candidates impacts culled registry).
B=$1
rounds=$2
workloads=("--bodies 1000" "--bodies 5000" "--bodies 10000" "--bodies 1000 --links 2"
           "--bodies 1000 --fast 0.1" "--bodies 10000 --3d 10" "--bodies 300 --links 3 --joints"
           "--bodies 1000 --links 3 --joints" "--bodies 300 --links 4 --joints"
           "--bodies 1000 --links 4 --joints")
for r in $(seq "$rounds"); do
  order=("${workloads[@]}")
  if [ $((r % 2)) = 0 ]; then
    order=()
    for ((i = ${#workloads[@]} - 1; i >= 0; --i)); do order+=("${workloads[i]}"); done
  fi
  for w in "${order[@]}"; do
    for threads in 1 0; do
      # shellcheck disable=SC2086
      line=$("$B" $w --threads "$threads" --cycles 40 --warmup 5 2>&1 | awk '/^ bodies/{getline; print}')
      echo "$r $threads $w | $line"
    done
  done
done
