#!/usr/bin/env python3
"""Interleaved comparison of two vadop_bench binaries (A B A B ..., or A B B A to cancel drift).

The machine drifts by up to 30% over minutes, so the two builds run in turn, each round on the
same arguments, and the figures are the medians over rounds of each run's per-frame CPU time
(frame_cpu_ms_median) with the spread (min-max) beside them.

    /usr/bin/python3 scripts/bench_compare.py --a OLD/vadop_bench --b NEW/vadop_bench --rounds 3 \
        --out docs/bench/compare -- --n 100000 --speed slow,medium,fast --methods vadop,grid --frames 10

Writes OUT/a.jsonl and OUT/b.jsonl (every run, with a "round" field) and prints a markdown table:
method, n, speed, A median (spread), B median (spread), B / A. Exits 1 when a run fails (a miss
is a failure of vadop_bench itself).
"""
import argparse
import json
import os
import statistics
import subprocess
import sys


def run(binary, args, label, rnd, out):
    cmd = [binary, "--json"] + args
    sys.stderr.write(f"[round {rnd}] {label}: {' '.join(cmd)}\n")
    proc = subprocess.run(cmd, stdout=subprocess.PIPE, text=True)
    if proc.returncode != 0:
        sys.stderr.write(f"{label} exited {proc.returncode}\n")
        return False
    with open(out, "a") as f:
        for line in proc.stdout.splitlines():
            try:
                rec = json.loads(line)
            except json.JSONDecodeError:
                continue
            rec["round"] = rnd
            f.write(json.dumps(rec) + "\n")
    return True


def load(path):
    runs = {}
    with open(path) as f:
        for line in f:
            rec = json.loads(line)
            if "method" not in rec or "frame_cpu_ms_median" not in rec:
                continue
            key = (rec["method"], rec["n"], rec["speed"])
            runs.setdefault(key, []).append(rec["frame_cpu_ms_median"])
    return runs


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--a", required=True, help="baseline vadop_bench binary")
    p.add_argument("--b", required=True, help="candidate vadop_bench binary")
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--out", required=True, help="directory for a.jsonl and b.jsonl")
    p.add_argument("--abba", action="store_true", help="order A B, B A, A B, ... (cancels a linear drift)")
    p.add_argument("args", nargs=argparse.REMAINDER, help="-- then the vadop_bench arguments")
    o = p.parse_args()
    args = o.args[1:] if o.args[:1] == ["--"] else o.args
    if o.rounds < 1:
        p.error("--rounds must be >= 1")
    os.makedirs(o.out, exist_ok=True)
    a_out, b_out = os.path.join(o.out, "a.jsonl"), os.path.join(o.out, "b.jsonl")
    for path in (a_out, b_out):
        open(path, "w").close()
    ok = True
    for r in range(1, o.rounds + 1):
        order = [("A", o.a, a_out), ("B", o.b, b_out)]
        if o.abba and r % 2 == 0:
            order.reverse()
        for label, binary, out in order:
            ok = run(binary, args, label, r, out) and ok
    a, b = load(a_out), load(b_out)
    print("| method | n | speed | A ms/frame median (min-max) | B ms/frame median (min-max) | B / A |")
    print("|---|---|---|---|---|---|")
    for key in sorted(set(a) | set(b), key=lambda k: (k[1], k[2], k[0])):
        def cell(v):
            return f"{statistics.median(v):.3g} ({min(v):.3g}-{max(v):.3g})" if v else "-"
        va, vb = a.get(key, []), b.get(key, [])
        ratio = f"{statistics.median(vb) / statistics.median(va):.2f}" if va and vb else "-"
        print(f"| {key[0]} | {key[1]} | {key[2]} | {cell(va)} | {cell(vb)} | {ratio} |")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
