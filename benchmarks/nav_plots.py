"""PNG plots of the worst runs of ``usv bench nav`` (``--plots DIR``): for each headline figure, the
true track of the cell where it was worst, in the phase it measures, with what was commanded."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.nav_metrics import MODE_AUTO, MODE_LOITER, MODE_RTL, Timeline, Truth, path_distance

PLOTTED = {
    "loiter_max_m_current_above_creep": "loiter",
    "loiter_max_m_current_below_creep": "loiter",
    "square_side_max_m": "square",
    "square_mid_leg_max_m": "square",
    "circle_error_max_m": "samples",
    "sample_distance_max_m": "samples",
    "fill_distance_max_m": "samples",
    "goto_overshoot_m": "goto",
    "rtl_overshoot_m": "rtl",
}
"""Figure -> the phase its plot shows."""


def _phase_window(tl: Timeline, phase: str, plan_corners: list[Any]) -> tuple[float, float]:
    t_loiter = tl.one("set_mode", MODE_LOITER)
    t_rtl = tl.one("set_mode", MODE_RTL)
    t_square, t_end = tl.one("set_mode", MODE_AUTO), tl.one("phase", "mission_done")
    t_samples = tl.reached(t_square, t_end).get(len(plan_corners), t_end)
    windows = {"goto": (tl.one("goto"), t_loiter), "loiter": (t_loiter, t_rtl), "rtl": (t_rtl, t_square),
               "square": (t_square, t_samples), "samples": (t_samples, t_end)}
    return windows[phase]


def plot_cell(result: dict[str, Any], figure: str, value: float, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    flight = result["flight"]
    plan = flight["plan"]
    truth = Truth(Path(flight["truth_csv"]), (flight["home"][0], flight["home"][1]))
    tl = Timeline(flight["events"])
    phase = PLOTTED[figure]
    t0, t1 = _phase_window(tl, phase, plan["square_ne"])
    idx = truth.window(t0, t1)
    fig, (ax, ax_t) = plt.subplots(1, 2, figsize=(12, 5.5))
    ax.plot(truth.e[idx], truth.n[idx], lw=1.0, color="tab:blue", label="boat (truth)")
    ax.plot(truth.e[idx[0]], truth.n[idx[0]], "o", color="tab:blue", ms=4)
    if phase == "loiter":
        entry = truth.at(t0)
        d = truth.dist(idx, entry)
        ax.plot(entry[1], entry[0], "k+", ms=12, label="LOITER entry point")
        ax_t.plot(truth.t[idx] - t0, d)
        ax_t.set_ylabel("distance from the entry point (m)")
    elif phase == "square":
        corners = [truth.at(t0), *[tuple(c) for c in plan["square_ne"]]]
        ax.plot([c[1] for c in corners], [c[0] for c in corners], "k--", lw=0.8, label="commanded path")
        sq = result["figures"]["square"]
        ax.plot(sq["side_max_at_ne"][1], sq["side_max_at_ne"][0], "rx", ms=10, label="farthest from a side")
        side = path_distance(np.stack([truth.n[idx], truth.e[idx]], axis=1), corners)
        ax_t.plot(truth.t[idx] - t0, side, label="distance to the nearest side")
        ax_t.set_ylabel("m")
        ax_t.legend(fontsize=8)
    elif phase == "samples":
        radius = result["figures"]["sampling"]["radius_m"]
        a = np.linspace(0, 2 * math.pi, 100)
        for k, (n, e) in enumerate(plan["sample_points_ne"]):
            ax.plot(e + radius * np.sin(a), n + radius * np.cos(a), "k--", lw=0.7,
                    label="commanded circles" if k == 0 else None)
            ax.plot(e, n, "k+", ms=8)
        pumping = idx[truth.pump[idx] == 1]
        ax.plot(truth.e[pumping], truth.n[pumping], ".", color="tab:red", ms=2, label="pump on")
        points = plan["sample_points_ne"]
        d = np.min([np.hypot(truth.n[idx] - p[0], truth.e[idx] - p[1]) for p in points], axis=0)
        ax_t.plot(truth.t[idx] - t0, d, label="distance to the nearest sampling point")
        ax_t.axhline(radius, color="k", ls="--", lw=0.7, label="circle radius")
        ax_t.axhline(radius + 0.6, color="tab:red", ls=":", lw=0.7, label="radius + 0.6 m")
        ax_t.set_ylabel("m")
        ax_t.legend(fontsize=8)
    else:
        point = tuple(plan["goto_ne"]) if phase == "goto" else (0.0, 0.0)
        ax.plot(point[1], point[0], "k+", ms=12, label="commanded point")
        ax_t.plot(truth.t[idx] - t0, truth.dist(idx, point))
        ax_t.set_ylabel("distance from the point (m)")
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    ax_t.set_xlabel(f"time in the {phase} phase (s)")
    ax_t.grid(alpha=0.3)
    fig.suptitle(f"worst {figure} = {value:.2f} m\n{result['name']}", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_worst(results: list[dict[str, Any]], worst: dict[str, dict[str, Any]], out_dir: Path) -> list[str]:
    """One PNG per figure of :data:`PLOTTED` (the cell where it was worst); returns the file names."""
    out_dir.mkdir(parents=True, exist_ok=True)
    by_name = {r["name"]: r for r in results if "flight" in r and "flat" in r}
    written = []
    for figure in PLOTTED:
        row = worst.get(figure, {})
        if row.get("cell") not in by_name:
            continue
        path = out_dir / f"worst_{figure}.png"
        plot_cell(by_name[row["cell"]], figure, float(row["value"]), path)
        written.append(str(path))
    return written
