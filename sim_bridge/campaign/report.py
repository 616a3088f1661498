"""``usv campaign report DIR --out REPORT``: a Markdown summary of a campaign's results with PNG plots.

Reads ``DIR/results.csv``, ``DIR/campaign.toml`` and ``DIR/tracks`` (:mod:`sim_bridge.campaign.results`)
and writes ``REPORT`` (Markdown) and, beside it, ``<stem>_success_vs_current.png`` (success rate per
current-speed bin, with each run's outcome), ``<stem>_figures_vs_<variable>.png`` (every figure of
the mission against each disturbance that varies) and ``<stem>_worst_tracks.png`` (the worst runs'
tracks).  The Markdown gives the success rate with its 95 % Wilson interval, success per
current-speed bin, the failure reasons counted, every figure's median / 90th percentile / worst
with the run it came from, the worst runs, and the campaign's throughput.
"""

from __future__ import annotations

import itertools
import math
import re
import tomllib
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np

from companion.config import ConfigError
from sim_bridge.campaign.results import CAMPAIGN_COPY, FIGURE_COLUMNS, read_rows, read_track
from sim_bridge.campaign.spec import VARIABLES

PRIMARY = ("circle_error_max_m", "launch_distance_error_m", "loiter_error_max_m", "path_deviation_max_m",
           "path_extent_m")
"""The figure that ranks runs from worst to best (the first one the campaign has)."""
NOT_FIGURES = ("mission_complete", "failsafe_events", "warnings", "samples_taken", "samples_within_tol",
               "launches", "launches_within_tol")
WORST_TRACKS = 4
CURRENT_BINS = 6


def _float(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        return math.nan


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """95 % Wilson score interval of a proportion k/n."""
    if n == 0:
        return (math.nan, math.nan)
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return (max(0.0, centre - half), min(1.0, centre + half))


def failure_kinds(texts: list[str]) -> Counter[str]:
    """Failure reasons with their numbers taken out, counted (one run may have several)."""
    out: Counter[str] = Counter()
    for text in texts:
        for part in filter(None, (p.strip() for p in text.split(";"))):
            out[re.sub(r"\d+(\.\d+)?", "#", part)] += 1
    return out


def write_report(results_dir: Path | str, report: Path | str) -> dict[str, Any]:
    """Write the report and its plots; a summary (runs, successes, plots)."""
    results_dir, report = Path(results_dir), Path(report)
    rows = read_rows(results_dir)
    if not rows:
        raise ConfigError(f"{results_dir}: no finished runs (results.csv is missing or empty)")
    rows.sort(key=lambda r: int(r["index"]))
    try:
        camp = tomllib.loads((results_dir / CAMPAIGN_COPY).read_text(encoding="utf-8")).get("campaign", {})
    except (OSError, tomllib.TOMLDecodeError):
        camp = {}
    name = str(camp.get("name", results_dir.name))
    col = {c: np.array([_float(r.get(c, "")) for r in rows]) for c in (*VARIABLES, *FIGURE_COLUMNS,
                                                                           "wall_s", "cpu_s")}
    index = np.array([int(r["index"]) for r in rows])
    success = np.array([r["success"] == "1" for r in rows])
    errors = [r for r in rows if r.get("error")]
    n, k = len(rows), int(success.sum())
    lo, hi = wilson(k, n)
    figures = [c for c in FIGURE_COLUMNS if c not in NOT_FIGURES and np.isfinite(col[c]).any()
               and c not in ("mission_time_s", "sim_time_s")]
    varying = [v for v in VARIABLES if v != "seed" and np.nanmax(col[v]) > np.nanmin(col[v])]
    primary = next((c for c in PRIMARY if c in figures), None)
    report.parent.mkdir(parents=True, exist_ok=True)
    stem = report.with_suffix("")
    plots: list[Path] = []

    lines = [f"# Campaign `{name}`", ""]
    if camp.get("description"):
        lines += [str(camp["description"]), ""]
    lines += [f"- runs: **{n}** (indices {index.min()}-{index.max()}), of which {len(errors)} ended in an "
              "error",
              f"- success: **{k} / {n} = {100.0 * k / n:.1f} %** (95 % Wilson interval "
              f"{100 * lo:.1f}-{100 * hi:.1f} %)"]
    sim, wall, cpu = np.nansum(col["sim_time_s"]), np.nansum(col["wall_s"]), np.nansum(col["cpu_s"])
    if wall > 0:
        lines.append(f"- simulated {sim:.0f} s in {wall:.0f} s of run wall time ({sim / wall:.1f} simulated "
                     f"s per wall s per worker; median {np.nanmedian(col['wall_s']):.2f} wall s per run, "
                     f"{cpu:.0f} CPU s in all)")
    lines.append("")

    speed = col["current_speed_mps"]
    if np.isfinite(speed).all():
        edges = np.linspace(float(speed.min()), float(speed.max()) + 1e-9, CURRENT_BINS + 1) \
            if speed.max() > speed.min() else np.array([speed.min(), speed.min() + 1e-9])
        lines += ["## Success against current speed", "", "| current (m/s) | runs | success |",
                  "|---|---|---|"]
        centres, rates, counts = [], [], []
        for a, b in itertools.pairwise(edges):
            sel = (speed >= a) & (speed < b)
            if sel.any():
                rate = float(success[sel].mean())
                lines.append(f"| {a:.2f}-{b:.2f} | {int(sel.sum())} | {100 * rate:.0f} % |")
                centres.append((a + b) / 2)
                rates.append(rate)
                counts.append(int(sel.sum()))
        lines.append("")
        plots.append(_plot_success(stem, speed, success, centres, rates, edges))

    kinds = failure_kinds([r["failures"] for r in rows if r["success"] != "1"])
    if kinds:
        lines += ["## Why runs failed", "", "| reason (numbers as #) | occurrences |", "|---|---|"]
        lines += [f"| {reason} | {count} |" for reason, count in kinds.most_common(12)]
        lines.append("")
    if errors:
        lines += ["Errors: " + "; ".join(f"run {r['index']}: {r['error']}" for r in errors[:5]), ""]

    if figures:
        lines += ["## Figures", "", "| figure | runs | median | 90th percentile | worst | worst run |",
                  "|---|---|---|---|---|---|"]
        for c in figures:
            x = col[c]
            ok = np.isfinite(x)
            worst = int(np.nanargmax(x))
            lines.append(f"| {c} | {int(ok.sum())} | {np.nanmedian(x):.3f} | {np.nanpercentile(x, 90):.3f} | "
                         f"{x[worst]:.3f} | {index[worst]} |")
        counts_line = []
        for c in ("samples_within_tol", "launches_within_tol", "failsafe_events"):
            if np.isfinite(col[c]).any():
                counts_line.append(f"{c} total {int(np.nansum(col[c]))}")
        if counts_line:
            lines += ["", "Counts: " + ", ".join(counts_line) + "."]
        lines.append("")
        for v in varying:
            plots.append(_plot_figures(stem, v, col[v], {c: col[c] for c in figures}, success))
        if varying:
            lines += ["Figures against each disturbance: " + ", ".join(f"`{p.name}`" for p in plots[1:]), ""]

    if primary is not None:
        ranked = np.argsort(-np.nan_to_num(col[primary], nan=-np.inf))
        order = [i for i in ranked if np.isfinite(col[primary][i])]
        worst_runs = [int(i) for i in order[:WORST_TRACKS]]
        lines += [f"## Worst runs by {primary}", "",
                  f"| run | {primary} | success | current (m/s, toward deg) | wind (m/s) | Hs (m) | "
                  "failures |",
                  "|---|---|---|---|---|---|---|"]
        for i in worst_runs:
            r = rows[i]
            lines.append(f"| {r['index']} | {col[primary][i]:.3f} | {'yes' if success[i] else 'no'} | "
                         f"{_float(r['current_speed_mps']):.2f}, {_float(r['current_toward_deg']):.0f} | "
                         f"{_float(r['wind_speed_mps']):.1f} | {_float(r['wave_hs_m']):.2f} | "
                         f"{r['failures']} |")
        tracks = [(rows[i], read_track(results_dir, int(rows[i]["index"]))) for i in worst_runs]
        tracks_plot = _plot_tracks(stem, primary, [(r, t) for r, t in tracks if t], col[primary], rows)
        if tracks_plot is not None:
            plots.append(tracks_plot)
            lines += ["", f"![worst tracks]({tracks_plot.name})"]
        lines.append("")
    if plots:
        lines += ["## Plots", "", *(f"![{p.stem}]({p.name})" for p in plots if not p.stem.endswith("tracks")),
                  ""]
    report.write_text("\n".join(lines), encoding="utf-8")
    return {"runs": n, "successes": k, "plots": [str(p) for p in plots], "figures": figures}


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _plot_success(stem: Path, speed: np.ndarray, success: np.ndarray, centres: list[float],
                  rates: list[float], edges: np.ndarray) -> Path:
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(7, 4))
    width = float(edges[1] - edges[0]) * 0.9 if len(edges) > 1 else 0.1
    ax.bar(centres, [100 * r for r in rates], width=width, color="tab:blue", alpha=0.4,
           label="success rate per bin")
    jitter = np.random.default_rng(0).uniform(-2.0, 2.0, len(speed))
    ax.scatter(speed, np.where(success, 100.0, 0.0) + jitter, s=10,
               c=np.where(success, "tab:green", "tab:red"), label="runs (succeeded at 100, failed at 0)")
    ax.set(xlabel="current speed [m/s]", ylabel="success [%]", ylim=(-8, 108),
           title="Success against current")
    ax.legend(loc="lower left", fontsize=8)
    ax.grid(True, alpha=0.3)
    path = Path(f"{stem}_success_vs_current.png")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def _plot_figures(stem: Path, variable: str, x: np.ndarray, figs: dict[str, np.ndarray],
                  success: np.ndarray) -> Path:
    plt = _pyplot()
    cols = min(3, len(figs))
    rows_n = math.ceil(len(figs) / cols)
    fig, axes = plt.subplots(rows_n, cols, figsize=(4.2 * cols, 3.2 * rows_n), squeeze=False)
    for ax, (name, y) in zip(axes.flat, figs.items(), strict=False):
        ax.scatter(x, y, s=10, c=np.where(success, "tab:green", "tab:red"))
        ax.set(xlabel=variable, ylabel=name)
        ax.grid(True, alpha=0.3)
    for ax in list(axes.flat)[len(figs):]:
        ax.axis("off")
    fig.suptitle(f"Figures against {variable} (green: run succeeded, red: failed)")
    path = Path(f"{stem}_figures_vs_{variable}.png")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


def _plot_tracks(stem: Path, primary: str, tracks: list[tuple[dict[str, str], dict[str, Any]]],
                 values: np.ndarray, rows: list[dict[str, str]]) -> Path | None:
    if not tracks:
        return None
    plt = _pyplot()
    fig, axes = plt.subplots(1, len(tracks), figsize=(4.5 * len(tracks), 4.5), squeeze=False)
    for ax, (row, track) in zip(axes.flat, tracks, strict=True):
        ax.plot(track["east_m"], track["north_m"], color="tab:green", lw=1.0)
        for north, east in track.get("marks_ne", []):
            ax.plot([east], [north], "rx")
        ax.plot([0.0], [0.0], "k^")
        v = values[rows.index(row)]
        ax.set(aspect="equal", xlabel="east of home [m]", ylabel="north of home [m]",
               title=f"run {row['index']}: {primary} {v:.2f}\n"
                     f"current {_float(row['current_speed_mps']):.2f} m/s "
                     f"toward {_float(row['current_toward_deg']):.0f} deg")
        ax.title.set_fontsize(9)
        ax.grid(True, alpha=0.3)
    path = Path(f"{stem}_worst_tracks.png")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path
