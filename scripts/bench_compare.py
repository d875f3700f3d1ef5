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

Methods of one build in turn (each method a process of its own, the order rotated every round):

    /usr/bin/python3 scripts/bench_compare.py --a BUILD/vadop_bench --methods-in-turn vadop,grid,fcl_refit \
        --rounds 3 --out DIR -- --n 100000 --speed slow,medium,fast --frames 10

writes OUT/methods.jsonl and prints, per n and speed, each method's median (min-max) and the
ratio of the first method to each other one within a round: median (min-max) over the rounds.
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


def load_rounds(path):
    """(method, n, speed) -> {round: frame_cpu_ms_median}"""
    runs = {}
    with open(path) as f:
        for line in f:
            rec = json.loads(line)
            if "method" not in rec or "frame_cpu_ms_median" not in rec:
                continue
            runs.setdefault((rec["method"], rec["n"], rec["speed"]), {})[rec["round"]] = rec["frame_cpu_ms_median"]
    return runs


def methods_in_turn(o, args):
    methods = o.methods_in_turn.split(",")
    out = os.path.join(o.out, "methods.jsonl")
    open(out, "w").close()
    ok = True
    for r in range(1, o.rounds + 1):
        k = (r - 1) % len(methods)
        for m in methods[k:] + methods[:k]:
            ok = run(o.a, args + ["--methods", m], m, r, out) and ok
    runs = load_rounds(out)
    first = methods[0]
    head = " | ".join(f"{m} ms/frame median (min-max)" for m in methods)
    ratios = " | ".join(f"{first} / {m} per round, median (min-max)" for m in methods[1:])
    print(f"| n | speed | {head} | {ratios} |")
    print("|---" * (2 + 2 * len(methods) - 1) + "|")
    for n, speed in sorted({(k[1], k[2]) for k in runs}):
        def cell(v):
            return f"{statistics.median(v):.3g} ({min(v):.3g}-{max(v):.3g})" if v else "-"
        cells = [cell(list(runs.get((m, n, speed), {}).values())) for m in methods]
        base = runs.get((first, n, speed), {})
        for m in methods[1:]:
            other = runs.get((m, n, speed), {})
            rr = [base[x] / other[x] for x in base if x in other and other[x] > 0]
            cells.append(f"{statistics.median(rr):.2f} ({min(rr):.2f}-{max(rr):.2f})" if rr else "-")
        print(f"| {n} | {speed} | " + " | ".join(cells) + " |")
    return 0 if ok else 1


def load(path):
    """(method, n, speed) -> [frame_cpu_ms_median of each round]"""
    return {key: list(by_round.values()) for key, by_round in load_rounds(path).items()}


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--a", required=True, help="baseline vadop_bench binary")
    p.add_argument("--b", help="candidate vadop_bench binary")
    p.add_argument("--methods-in-turn", help="instead of --b: these methods of --a, one process each, in turn")
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--out", required=True, help="directory for a.jsonl and b.jsonl")
    p.add_argument("--abba", action="store_true", help="order A B, B A, A B, ... (cancels a linear drift)")
    p.add_argument("args", nargs=argparse.REMAINDER, help="-- then the vadop_bench arguments")
    o = p.parse_args()
    args = o.args[1:] if o.args[:1] == ["--"] else o.args
    if o.rounds < 1:
        p.error("--rounds must be >= 1")
    os.makedirs(o.out, exist_ok=True)
    if o.methods_in_turn:
        return methods_in_turn(o, args)
    if not o.b:
        p.error("give --b, or --methods-in-turn")
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
