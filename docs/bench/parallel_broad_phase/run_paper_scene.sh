#!/bin/bash
# The paper's scene (vadop_bench, n = 100,000, slow, medium and fast), VADOP and the plain grid,
# this build (NEW) against a build of the commit before (OLD), 3 rounds, the order swapped each
# round. One thread: the bench drives the broad phases directly.
NEW=${NEW:-/work/b/rel/vadop_bench}
OLD=${OLD:-/work/b/coreh/vadop_bench}
out=${OUT:-/tmp/paper_scene.txt}; : > "$out"
for r in 1 2 3; do
  if [ $((r % 2)) = 1 ]; then order="new old"; else order="old new"; fi
  for build in $order; do
    bin=$NEW; [ "$build" = old ] && bin=$OLD
    (cd /tmp && "$bin" --n 100000 --speed slow,medium,fast --methods vadop,grid --frames 20) 2>&1 |
      grep -E "^(vadop|grid) " | sed "s/^/r$r $build /" >> "$out"
  done
done
echo finished >> "$out"
