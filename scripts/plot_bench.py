#!/usr/bin/python3
"""Charts from the JSON lines of `vadop_bench --json` (one object per method, n, speed, m, phi).

usage: /usr/bin/python3 scripts/plot_bench.py RESULTS.jsonl [MORE.jsonl ...] [--out DIR]

Writes into DIR (default: the directory of the first input):
  frame_time_vs_n.png      median time per frame (CPU time of the thread) against n, one panel
                           per speed (log-log)
  candidates_vs_speed.png  candidate pairs per frame against speed, one panel per n (log-log)
  cost_split.png           share of c_u, c_s, c_t, c_r (medians of each part) per method, with the
                           median ms per frame, one panel per speed, at the largest n measured
  vadop_m_sweep.png        VADOP and fixed k-DOP time per frame against the pool size m
  pseudo_dynamic_misses.png  share of the true impacts that pseudo-dynamic detection misses
  summary.md               the figures as Markdown tables, with VADOP / best peer ratios
Needs Debian's python3-matplotlib (run with /usr/bin/python3).
"""
import argparse
import collections
import json
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

COLORS = {
    "vadop": "tab:red",
    "vadop_rebuild": "salmon",
    "vadop_sap": "tab:olive",
    "kdop": "tab:purple",
    "sap": "tab:orange",
    "fcl_refit": "tab:blue",
    "fcl_rebuild": "tab:cyan",
    "bullet": "tab:green",
    "brute": "black",
    "grid": "tab:gray",
    "fcl_discrete_refit": "tab:brown",
    "fcl_discrete_rebuild": "tab:pink",
}
MARKERS = ["o", "s", "^", "D", "v", "P", "X", "*"]


def load(paths):
    rows = []
    for path in paths:
        with open(path, encoding="utf-8") as f:
            for lineno, line in enumerate(f, 1):
                line = line.strip()
                if not line:
                    continue
                try:
                    row = json.loads(line)
                except json.JSONDecodeError as e:
                    sys.exit(f"{path}:{lineno}: not JSON: {e}")
                if "error" in row:
                    print(f"{path}:{lineno}: skipped failed run {row.get('method')}: {row['error']}", file=sys.stderr)
                    continue
                rows.append(row)
    if not rows:
        sys.exit("no results to plot")
    return rows


def label(row, many_phi):
    s = row["method"]
    if row["method"] in ("vadop", "vadop_rebuild", "vadop_sap", "kdop") and row.get("m") is not None:
        s += f" m={row['m']}"
    if row["method"] in ("vadop", "vadop_rebuild", "vadop_sap") and many_phi and row.get("phi") is not None:
        s += f" phi={row['phi']:g}"
    return s


def style(lab, method, index):
    ls = "--" if method.startswith("fcl_discrete") else "-"
    return dict(color=COLORS.get(method, None), linestyle=ls, marker=MARKERS[index % len(MARKERS)])


def legend_all(fig, axes):
    """One legend for every line of every panel (a method may be missing from some panels)."""
    seen = collections.OrderedDict()
    for ax in axes:
        for h, lab in zip(*ax.get_legend_handles_labels()):
            seen.setdefault(lab, h)
    fig.legend(list(seen.values()), list(seen.keys()), fontsize=7, loc="center left", bbox_to_anchor=(1.0, 0.5))


def speed_name(s):
    return {0.1: "slow", 1.0: "medium", 10.0: "fast"}.get(s, "")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("inputs", nargs="+")
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    rows = load(args.inputs)
    out = args.out or os.path.dirname(os.path.abspath(args.inputs[0]))
    os.makedirs(out, exist_ok=True)

    many_phi = len({r["phi"] for r in rows if r["method"] == "vadop"}) > 1
    for r in rows:
        r["label"] = label(r, many_phi)
    speeds = sorted({r["speed"] for r in rows})
    ns = sorted({r["n"] for r in rows})
    labels = list(collections.OrderedDict((r["label"], r["method"]) for r in rows).items())

    # 1. Time per frame against n (CPU time of the thread when measured: the machine is shared).
    tkey = "frame_cpu_ms_median" if all("frame_cpu_ms_median" in r for r in rows) else "frame_ms_median"
    tname = "CPU" if tkey == "frame_cpu_ms_median" else "wall-clock"
    fig, axes = plt.subplots(1, len(speeds), figsize=(5.2 * len(speeds), 4.6), squeeze=False)
    for ax, sp in zip(axes[0], speeds):
        for i, (lab, method) in enumerate(labels):
            pts = sorted((r["n"], r[tkey]) for r in rows if r["label"] == lab and r["speed"] == sp and r[tkey] > 0)
            if pts:
                ax.plot([p[0] for p in pts], [p[1] for p in pts], label=lab, **style(lab, method, i))
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("n (spheres)")
        ax.set_ylabel(f"median {tname} time per frame (ms)")
        ax.set_title(f"speed {sp:g} radii/frame {speed_name(sp)}")
        ax.grid(True, which="both", alpha=0.3)
    legend_all(fig, axes[0])
    fig.suptitle("Time per frame (broad + narrow phase + responses); dashed: pseudo-dynamic (discrete)")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "frame_time_vs_n.png"), dpi=110, bbox_inches="tight")
    plt.close(fig)

    # 2. Candidates against speed.
    fig, axes = plt.subplots(1, len(ns), figsize=(4.6 * len(ns), 4.4), squeeze=False)
    for ax, n in zip(axes[0], ns):
        for i, (lab, method) in enumerate(labels):
            pts = sorted((r["speed"], r["candidates"]) for r in rows if r["label"] == lab and r["n"] == n
                         and r["candidates"] > 0)
            if pts:
                ax.plot([p[0] for p in pts], [p[1] for p in pts], label=lab, **style(lab, method, i))
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("speed (radii per frame)")
        ax.set_ylabel("candidate pairs per frame")
        ax.set_title(f"n = {n:,}")
        ax.grid(True, which="both", alpha=0.3)
    legend_all(fig, axes[0])
    fig.suptitle("Broad-phase candidate pairs per frame (the swept-AABB peers share one curve: same boxes;"
                 " brute = exact swept-sphere pairs)")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "candidates_vs_speed.png"), dpi=110, bbox_inches="tight")
    plt.close(fig)

    # 3. Cost split at the largest n: each part's share (a stacked log scale would distort the
    # proportions), with the median time per frame written above each bar.
    nmax = ns[-1]
    parts = [("update_ms", "c_u update"), ("sort_ms", "c_s sort/pairs"), ("test_ms", "c_t narrow phase"),
             ("response_ms", "c_r response")]
    part_colors = ["tab:blue", "tab:orange", "tab:green", "tab:red"]
    fig, axes = plt.subplots(1, len(speeds), figsize=(5.5 * len(speeds), 5.0), squeeze=False)
    order = [l for l, _ in labels]
    for ax, sp in zip(axes[0], speeds):
        sel = [r for r in rows if r["n"] == nmax and r["speed"] == sp]
        sel.sort(key=lambda r: order.index(r["label"]))
        x = list(range(len(sel)))
        sums = [sum(r[k] for k, _ in parts) or 1.0 for r in sel]
        bottom = [0.0] * len(sel)
        for (key, name), c in zip(parts, part_colors):
            vals = [100.0 * r[key] / t for r, t in zip(sel, sums)]
            ax.bar(x, vals, bottom=bottom, color=c, label=name)
            bottom = [b + v for b, v in zip(bottom, vals)]
        for xi, r in zip(x, sel):
            ax.text(xi, 101, f"{r['frame_ms_median']:.3g}", ha="center", va="bottom", fontsize=6, rotation=90)
        ax.set_xticks(x)
        ax.set_xticklabels([r["label"] for r in sel], rotation=60, ha="right", fontsize=7)
        ax.set_ylim(0, 125)
        ax.set_yticks([0, 25, 50, 75, 100])
        ax.set_ylabel("share of the frame (%), medians of each part")
        ax.set_title(f"n = {nmax:,}, speed {sp:g} {speed_name(sp)}")
    axes[0][0].legend(fontsize=7, loc="upper left", ncol=2)
    fig.suptitle("Cost split c_u + c_s + c_t + c_r (the paper's model; c_r includes the mid-frame re-queries);"
                 " above the bars: median ms per frame")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "cost_split.png"), dpi=110)
    plt.close(fig)

    # 4. m sweep (VADOP and k-DOP), at each n, per speed.
    sweep = [r for r in rows if r["method"] in ("vadop", "vadop_sap", "kdop") and r.get("m")]
    if sweep:
        fig, axes = plt.subplots(1, len(speeds), figsize=(5.2 * len(speeds), 4.4), squeeze=False)
        for ax, sp in zip(axes[0], speeds):
            i = 0
            for method in ("vadop", "vadop_sap", "kdop"):
                for n in ns:
                    pts = sorted((r["m"], r[tkey]) for r in sweep
                                 if r["method"] == method and r["n"] == n and r["speed"] == sp and r[tkey] > 0)
                    if len(pts) < 1:
                        continue
                    ax.plot([p[0] for p in pts], [p[1] for p in pts], label=f"{method} n={n:,}",
                            color=COLORS[method], marker=MARKERS[i % len(MARKERS)],
                            alpha=0.35 + 0.65 * (ns.index(n) + 1) / len(ns))
                    i += 1
            ax.set_xscale("log", base=2)
            ax.set_yscale("log")
            ax.set_xlabel("pool size m (axes)")
            ax.set_ylabel(f"median {tname} time per frame (ms)")
            ax.set_title(f"speed {sp:g} {speed_name(sp)}")
            ax.grid(True, which="both", alpha=0.3)
        legend_all(fig, axes[0])
        fig.suptitle("Which pool size suits which speed (VADOP: velocity-aligned axes; k-DOP: every axis)")
        fig.tight_layout()
        fig.savefig(os.path.join(out, "vadop_m_sweep.png"), dpi=110, bbox_inches="tight")
        plt.close(fig)

    # 5. Pseudo-dynamic misses.
    disc = [r for r in rows if not r.get("continuous", True) and r.get("missed") is not None
            and r.get("reference_impacts")]
    if disc:
        fig, ax = plt.subplots(figsize=(6.0, 4.4))
        i = 0
        for method in sorted({r["method"] for r in disc}):
            for n in ns:
                pts = sorted((r["speed"], r["missed"] / r["reference_impacts"]) for r in disc
                             if r["method"] == method and r["n"] == n)
                if pts:
                    ax.plot([p[0] for p in pts], [100 * p[1] for p in pts], label=f"{method} n={n:,}",
                            color=COLORS.get(method), marker=MARKERS[i % len(MARKERS)], linestyle="--")
                    i += 1
        ax.set_xscale("log")
        ax.set_xlabel("speed (radii per frame)")
        ax.set_ylabel("true impacts missed (%)")
        ax.set_ylim(0, 100)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
        ax.set_title("Pseudo-dynamic detection at the frame poses:\nmissed share of the continuous reference's impacts")
        fig.tight_layout()
        fig.savefig(os.path.join(out, "pseudo_dynamic_misses.png"), dpi=110)
        plt.close(fig)

    write_summary(rows, labels, ns, speeds, os.path.join(out, "summary.md"))
    print(f"charts and summary.md written to {out}")


def write_summary(rows, labels, ns, speeds, path):
    """Markdown tables: per (n, speed) every method's times, candidates, impacts, misses, memory;
    then VADOP (its best m) against the best continuous peer (the plain grid included)."""
    order = [l for l, _ in labels]
    peers = {"sap", "grid", "fcl_refit", "fcl_rebuild", "bullet"}
    lines = ["# vadop_bench summary", "",
             "cpu = median CPU time of the thread per frame (p95 in parentheses); wall = median wall-clock time per frame (p95 in "
             "parentheses); c_u/c_s/c_t/c_r = medians of each part (wall); cand = candidate pairs per frame; "
             "impacts = sphere-sphere responses over all frames; missed = impacts of the reference the method did "
             "not report (continuous methods: same path; pseudo-dynamic: vs the continuous reference from the same "
             "state, as missed/true); rss = peak RSS of the method's own process (MB).", ""]
    for n in ns:
        for sp in speeds:
            sel = [r for r in rows if r["n"] == n and r["speed"] == sp]
            if not sel:
                continue
            sel.sort(key=lambda r: order.index(r["label"]))
            lines += [f"## n = {n:,}, speed {sp:g} radii/frame {speed_name(sp)}", "",
                      "| method | frames | cpu ms (p95) | wall ms (p95) | c_u | c_s | c_t | c_r | cand | impacts | missed | rss MB |",
                      "|---|---|---|---|---|---|---|---|---|---|---|---|"]
            for r in sel:
                if r.get("continuous", True):
                    missed = f"{r['missed']}"
                else:
                    missed = f"{r['missed']}/{r.get('reference_impacts', '?')}"
                frames = f"{r['frames']}" + (" (truncated)" if r.get("truncated") else "")
                lines.append(
                    f"| {r['label']} | {frames} | {r.get('frame_cpu_ms_median', float('nan')):.3g} "
                    f"({r.get('frame_cpu_ms_p95', float('nan')):.3g}) | "
                    f"{r['frame_ms_median']:.3g} ({r['frame_ms_p95']:.3g}) | {r['update_ms']:.3g} | {r['sort_ms']:.3g} | "
                    f"{r['test_ms']:.3g} | {r['response_ms']:.3g} | {r['candidates']:.0f} | {r['impacts']} | {missed} | "
                    f"{r['peak_rss_mb']:.1f} |")
            vad = [r for r in sel if r["method"] == "vadop"]
            peer = [r for r in sel if r["method"] in peers]
            if vad and peer:
                key = "frame_cpu_ms_median" if all("frame_cpu_ms_median" in r for r in vad + peer) else "frame_ms_median"
                bv = min(vad, key=lambda r: r[key])
                bp = min(peer, key=lambda r: r[key])
                ratio = bv[key] / bp[key] if bp[key] > 0 else float("inf")
                lines += ["", f"Best VADOP ({bv['label']}, {bv[key]:.3g} ms) / best swept-AABB peer "
                              f"({bp['label']}, {bp[key]:.3g} ms) = **{ratio:.2f}** ({key})."]
                # The broad phase alone (c_u + c_s, wall medians): what the method itself costs.
                bpv = bv["update_ms"] + bv["sort_ms"]
                bpp = min(r["update_ms"] + r["sort_ms"] for r in peer)
                if bpp > 0:
                    lines.append(f"Broad phase alone (c_u + c_s): {bpv:.3g} ms against the best peer's {bpp:.3g} ms = "
                                 f"**{bpv / bpp:.2f}**.")
                disc = [r for r in sel if r["method"].startswith("fcl_discrete") and key in r]
                if disc:
                    bd = min(disc, key=lambda r: r[key])
                    lines.append(f"Against pseudo-dynamic detection ({bd['label']}, {bd[key]:.3g} ms, missing "
                                 f"{bd['missed']} of {bd.get('reference_impacts', '?')} impacts): "
                                 f"**{bv[key] / bd[key]:.2f}**.")
            lines.append("")
    # Growth of the cost with n: exponent of the CPU time per frame between the smallest and the
    # largest n measured (target: no steeper than n^1.2), and of the peak memory.
    if len(ns) > 1:
        lines += [f"## Growth from n = {ns[0]:,} to n = {ns[-1]:,}", "",
                  "Exponent k in time ~ n^k (CPU per frame) and in peak RSS ~ n^k, per method and speed.", "",
                  "| method | speed | time exponent | memory exponent |", "|---|---|---|---|"]
        for lab in order:
            for sp in speeds:
                a = [r for r in rows if r["label"] == lab and r["speed"] == sp and r["n"] == ns[0]]
                b = [r for r in rows if r["label"] == lab and r["speed"] == sp and r["n"] == ns[-1]]
                if not a or not b or b[0].get("truncated"):
                    continue
                key = "frame_cpu_ms_median" if "frame_cpu_ms_median" in a[0] else "frame_ms_median"
                if a[0][key] <= 0 or b[0][key] <= 0:
                    continue
                dn = math.log(ns[-1] / ns[0])
                kt = math.log(b[0][key] / a[0][key]) / dn
                km = math.log(b[0]["peak_rss_mb"] / a[0]["peak_rss_mb"]) / dn
                lines.append(f"| {lab} | {sp:g} | {kt:.2f} | {km:.2f} |")
        lines.append("")
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
