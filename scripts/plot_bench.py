#!/usr/bin/python3
"""Plots of scripts/bench.sh's time-against-error run (tests/bench/time_error.cpp).

    plot_bench.py DIR      reads DIR/timing.csv, DIR/summary.csv and DIR/strip/*.png; writes
                           DIR/error-vs-time.png        ghost layer, rel. L2 vs wall time, log-log
                           DIR/error-vs-time-binned.png the ghost layer after binning both images (bin × bin
                                                        pixels: the preview's fair comparison)
                           DIR/error-vs-time-flare.png  the whole flare image, the same way
                           DIR/strip.png                reference | preview | guided | naive at equal time

Needs matplotlib (Debian: python3-matplotlib; scripts/setup.sh --bench installs it).
"""
import csv
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.image as mpimg  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402

LENS = {"double-gauss-50mm": "double Gauss 50 mm", "zoom-24-70mm": "zoom 24-70 mm", "fisheye-16mm": "fisheye 16 mm"}
STYLE = {
    "guided": dict(color="tab:blue", marker="o", ms=3, lw=1.2),
    "photons": dict(color="tab:purple", marker="v", ms=3, lw=1.0, ls="--"),
    "naive": dict(color="tab:red", marker="s", ms=3, lw=1.2),
}
PREVIEW = {
    "preview": dict(color="tab:green", marker="^", ms=7, ls="none"),
    "preview-fine": dict(color="tab:olive", marker="D", ms=6, ls="none"),
}


def case_title(s):
    zoom = f" ({s['zoom']})" if s["zoom"] else ""
    return f"{LENS.get(s['lens'], s['lens'])}{zoom}, sun ({s['field_x_deg']}°, {s['field_y_deg']}°)"


def grid(n):
    cols = 2 if n > 1 else 1
    return (n + cols - 1) // cols, cols


def error_plot(rows, summary, metric, path, ylabel):
    cases = [s["case"] for s in summary]
    nr, nc = grid(len(cases))
    fig, axes = plt.subplots(nr, nc, figsize=(5.2 * nc, 3.6 * nr), squeeze=False)
    for ax, s in zip(axes.flat, summary):
        c = s["case"]
        target = float(s["target"])
        mine = [r for r in rows if r["case"] == c]
        for m in ("guided", "photons", "naive"):
            pts = [(float(r["seconds"]), float(r[metric])) for r in mine if r["method"] == m and float(r[metric]) > 0]
            if pts:
                ax.plot(*zip(*pts), label=m, **STYLE[m])
        for m, st in PREVIEW.items():
            for r in mine:
                if r["method"] == m and float(r[metric]) > 0:
                    ax.plot([float(r["seconds"])], [float(r[metric])], label=m, **st)
        ref = [r for r in mine if r["method"] == "reference"]
        if ref and float(ref[0][metric]) > 0:
            ax.axhline(float(ref[0][metric]), color="grey", ls=":", lw=1, label="reference's own error")
        if metric.startswith("ghost_rel_l2"):
            ax.axhline(target, color="black", ls="--", lw=0.8, label=f"{target:.0%} target")
            if s["naive_t_kind"] == "extrapolated" and metric == "ghost_rel_l2":
                t0, e0 = float(s["naive_last_s"]), float(s["naive_last_ghost_err"])
                t1 = float(s["naive_t"])
                if e0 > 0 and t1 > t0:
                    ax.plot([t0, t1], [e0, target], color="tab:red", ls="--", lw=1,
                            label="naive, extrapolated ∝ t^-1/2")
                    ax.plot([t1], [target], color="tab:red", marker="x", ms=7, ls="none")
            ax.set_title(f"{case_title(s)}\nguided over naive at {target:.0%}: {float(s['speedup']):.0f}×"
                         + (" (extrapolated)" if s["naive_t_kind"] == "extrapolated" else ""), fontsize=9)
        else:
            ax.set_title(case_title(s), fontsize=9)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("wall time (s), 2 threads")
        ax.set_ylabel(ylabel)
        ax.grid(True, which="both", lw=0.3, alpha=0.5)
        ax.legend(fontsize=6, loc="best")
    for ax in list(axes.flat)[len(summary):]:
        ax.axis("off")
    fig.tight_layout()
    fig.savefig(path, dpi=72)
    plt.close(fig)


def strip(summary, stripdir, path):
    cols = [("reference", "reference"), ("preview", "preview"), ("guided", "guided"), ("naive", "naive")]
    present = [s for s in summary if os.path.exists(os.path.join(stripdir, f"{s['case']}-reference.png"))]
    if not present:
        return
    fig, axes = plt.subplots(len(present), 4, figsize=(10, 1.9 * len(present) + 0.3), squeeze=False)
    for row, s in zip(axes, present):
        c = s["case"]
        titles = {
            "reference": f"reference ({float(s['ref_seconds']):.0f} s)",
            "preview": f"preview {float(s['preview_s']):.2f} s, e={float(s['preview_ghost_err']):.3f}",
            "guided": f"guided {float(s['strip_guided_s']):.2f} s, e={float(s['strip_guided_ghost_err']):.3f}",
            "naive": (f"naive {float(s['strip_naive_s']):.2f} s, e={float(s['strip_naive_ghost_err']):.2f}"
                      + (" (its last)" if float(s["strip_naive_s"]) < float(s["strip_guided_s"]) else "")),
        }
        for ax, (key, _) in zip(row, cols):
            f = os.path.join(stripdir, f"{c}-{key}.png")
            if os.path.exists(f):
                ax.imshow(mpimg.imread(f), interpolation="nearest")
            ax.set_xticks([])
            ax.set_yticks([])
            ax.set_title(titles[key], fontsize=7)
        row[0].set_ylabel(c, fontsize=8)
    fig.suptitle("renders at equal time (the guided render's time to the target); e = ghost-layer rel. L2", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=56)
    plt.close(fig)


def main():
    d = sys.argv[1] if len(sys.argv) > 1 else "out/bench"
    with open(os.path.join(d, "timing.csv")) as f:
        rows = list(csv.DictReader(f))
    with open(os.path.join(d, "summary.csv")) as f:
        summary = list(csv.DictReader(f))
    error_plot(rows, summary, "ghost_rel_l2", os.path.join(d, "error-vs-time.png"), "ghost layer: relative L2 error")
    bins = {r["bin"] for r in rows}
    error_plot(rows, summary, "ghost_rel_l2_binned", os.path.join(d, "error-vs-time-binned.png"),
               f"ghost layer, {'/'.join(sorted(bins))}-px bins: rel. L2")
    error_plot(rows, summary, "flare_rel_l2", os.path.join(d, "error-vs-time-flare.png"), "whole flare: relative L2 error")
    strip(summary, os.path.join(d, "strip"), os.path.join(d, "strip.png"))
    for name in ("error-vs-time.png", "error-vs-time-binned.png", "error-vs-time-flare.png", "strip.png"):
        p = os.path.join(d, name)
        if os.path.exists(p):
            print(f"wrote {p}")
    # Headline table on stdout (Markdown).
    print("\n| case | guided to target | guided photons to target | naive to target | over photons | over naive "
          "| preview: time, ghost err (binned) |")
    print("|---|---|---|---|---|---|---|")
    for s in summary:
        print(f"| {s['case']} | {float(s['guided_t']):.3g} s ({s['guided_t_kind']}) | {float(s['photons_t']):.3g} s "
              f"({s['photons_t_kind']}) | {float(s['naive_t']):.3g} s ({s['naive_t_kind']}) | "
              f"{float(s['speedup_over_photons']):.1f}× | {float(s['speedup']):.0f}× | {float(s['preview_s']):.2f} s, "
              f"{float(s['preview_ghost_err']):.3f} ({float(s['preview_binned_ghost_err']):.3f}) |")


if __name__ == "__main__":
    main()
