"""Identification pipeline shared by ``usv identify``, its tests and ``usv bench``.

``identify_models(train)`` fits the Table 3 models (linearised speed-and-steering, Nomoto
with first-order sideslip, the qLPV model of Eq. 3-4, and optionally the qLPV model refined
by output error); ``validate(models, val)`` returns the J table of Eq. 12,
``table[model][mode][dof]`` with modes free-run, 1-s-ahead without model error and 1-s-ahead
with the UKF-estimated model error held (the active model, Eq. 5-11).  The same two
functions are what the done-when tests assert on, so the CLI and the tests cannot disagree.
"""

from __future__ import annotations

import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import TextIO

import numpy as np

from companion.models.active_prediction import FilterRun, predict_active, predict_plain, run_filter
from companion.models.base import DOF_NAMES, LinearInParamsModel
from companion.models.baselines import LinearizedModel, NomotoSideslipModel
from companion.models.current import CurrentFit, LogCurrent, estimate_currents, water_relative
from companion.models.evaluate import (
    MODES,
    Evaluation,
    active_ahead,
    horizon_sweep,
    j_of,
    j_table,
    reference,
    reference_name,
)
from companion.models.identify import (
    QLPV_DISSIPATIVE,
    FitResult,
    Progress,
    fit_least_squares,
    fit_qlpv,
    refine_instrumental,
    refine_output_error,
)
from companion.models.logs import Record
from companion.models.persistence import HeldErrorBound, held_error_bound
from companion.models.qlpv import QLPVModel
from companion.models.ukf import UKFSettings

MODEL_ORDER: tuple[str, ...] = ("linearized", "nomoto_sideslip", "qlpv", "qlpv_oe")
MODEL_TITLES: dict[str, str] = {"linearized": "Linearized", "nomoto_sideslip": "Nomoto with sideslip",
                                "qlpv": "qLPV", "qlpv_oe": "qLPV (output-error refined)"}
MODE_TITLES: dict[str, str] = {"free_run": "free run", "ahead": "1 s ahead, no model error",
                               "ahead_active": "1 s ahead, active model (UKF delta_nu held)"}

JTable = dict[str, dict[str, dict[str, float]]]
"""``table[model][mode][dof]``: J of Eq. 12 (a fraction; 0.05 = 5 %)."""


ESTIMATORS: tuple[str, ...] = ("iv", "ls")
"""``iv``: least squares, then instrumental variables with the qLPV damping kept dissipative
(the default; see :func:`companion.models.identify.refine_instrumental`); ``ls``: least
squares only.  Every model is fitted with the same smoothing and the same estimator."""


CURRENT_CHOICES: tuple[str, ...] = ("auto", "none")
"""``auto``: when every training log has a heading, estimate each log's current and fit every
model on water-relative velocities (:mod:`companion.models.current`; a current that is not
significant is left out, so calm logs fit exactly as over ground); ``none``: over ground."""


def identify_models(train: Sequence[Record], *, window_s: float = 2.0, refine: bool = False,
                    progress: Progress | None = None, estimator: str = "iv", current: str = "auto"
                    ) -> dict[str, FitResult]:
    """Fits of every model on the training records (+ output-error qLPV when ``refine``), on
    water-relative velocities when ``current`` is "auto" and the logs allow it."""
    if estimator not in ESTIMATORS:
        raise ValueError(f"estimator {estimator!r}: accepted: {', '.join(ESTIMATORS)}")
    if current not in CURRENT_CHOICES:
        raise ValueError(f"current {current!r}: accepted: {', '.join(CURRENT_CHOICES)}")
    currents: CurrentFit | None = None
    qlpv_ls: FitResult | None = None
    notes: list[str] = []
    if current == "auto":
        no_heading = [r.name for r in train if r.psi_rad is None]
        if no_heading:
            notes.append(f"no heading column 'psi' in {', '.join(no_heading)}: fitted over ground "
                         "(a current in the water would be taken for the hull's dynamics)")
        else:
            over_ground = fit_qlpv(train, window_s, name="qlpv")
            c0 = over_ground.model
            assert isinstance(c0, QLPVModel)
            currents = estimate_currents(train, c0.thrust_speed_coeff, window_s)
            relative = [water_relative(r, c) for r, c in zip(train, currents.currents, strict=True)]
            if all(a is b for a, b in zip(relative, train, strict=True)):
                qlpv_ls = over_ground  # no current taken out: the same records, the same fit
            train = relative
    fits = _fit_all(train, window_s, refine, progress, estimator, qlpv_ls)
    for fit in fits.values():
        fit.currents = currents
        fit.warnings[:0] = notes
    return fits


def _fit_all(train: Sequence[Record], window_s: float, refine: bool, progress: Progress | None,
             estimator: str, qlpv_ls: FitResult | None = None) -> dict[str, FitResult]:
    """Every model fitted on ``train``; ``qlpv_ls``: the qLPV least-squares fit of these very
    records if already made (it is deterministic, so it is not made twice)."""
    zeros = np.zeros((3, 6))
    fits = {
        "linearized": fit_least_squares(LinearizedModel(zeros, name="linearized"), train, window_s),
        "nomoto_sideslip": fit_least_squares(NomotoSideslipModel(zeros, name="nomoto_sideslip"), train,
                                             window_s),
        "qlpv": qlpv_ls if qlpv_ls is not None else fit_qlpv(train, window_s, name="qlpv"),
    }
    if estimator == "iv":
        fits = {name: refine_instrumental(fit, train, window_s,
                                          bounds=QLPV_DISSIPATIVE if name == "qlpv" else None)
                for name, fit in fits.items()}
    if refine:
        oe = refine_output_error(fits["qlpv"], train, progress=progress, bounds=QLPV_DISSIPATIVE)
        oe.model = replace(oe.model, name="qlpv_oe")
        fits["qlpv_oe"] = oe
    return fits


@dataclass
class CurrentFilterResult:
    """The qLPV model with the current-augmented UKF on one validation record."""

    settings: UKFSettings
    j: dict[str, dict[str, float]]
    """``j["ahead"]`` (the model alone from this filter's estimate) and ``j["ahead_active"]``."""
    current: LogCurrent
    """The current the filter estimated, averaged over the last third of the record."""
    weight: float
    """The mean weight the active model gave that current over the last third (0..1)."""

    @property
    def ratio(self) -> dict[str, float]:
        """Active over the model alone, 1 s ahead, per DOF (the chapter's Table 4 comparison)."""
        return {d: self.j["ahead_active"][d] / self.j["ahead"][d] if self.j["ahead"][d] > 0 else float("nan")
                for d in DOF_NAMES}


@dataclass
class Validation:
    """The J table of one validation record and the evaluations behind it (for plots)."""

    record: Record
    table: JTable
    evaluations: dict[str, Evaluation]
    reference: str
    settings: UKFSettings = field(default_factory=UKFSettings)
    held_bound: HeldErrorBound | None = None
    """For the qLPV model: model-error persistence over the horizon and the active/no-error ratio
    a perfect UKF would give on this record (:mod:`companion.models.persistence`)."""
    identified_settings: UKFSettings | None = None
    """UKF noise identified from the training logs (:mod:`companion.models.noise_fit`), if given."""
    active_identified: dict[str, float] | None = None
    """J (1 s ahead, delta_nu held) of the qLPV model with ``identified_settings``."""
    current_filter: CurrentFilterResult | None = None
    """The qLPV model with the current filter (when the record has a heading and it was asked)."""
    sweep: list[dict[str, object]] = field(default_factory=list)
    """Horizon sweep of the qLPV model (:func:`companion.models.evaluate.horizon_sweep`)."""


def validate(models: Mapping[str, LinearInParamsModel], rec: Record, *, horizon_s: float = 1.0,
             settings: UKFSettings | None = None, identified_settings: UKFSettings | None = None,
             current_settings: UKFSettings | None = None, backend: str = "native", sweep: bool = False
             ) -> Validation:
    """J per model, prediction mode and DOF on ``rec`` (see :mod:`companion.models.evaluate`),
    the held-model-error bound of the qLPV model, and for the qLPV model: with
    ``identified_settings`` its active 1-s-ahead J with that UKF noise, with
    ``current_settings`` (and a heading in the log) the current filter's figures, and with
    ``sweep`` the horizon sweep of every filter run.  ``backend``: the UKF implementation."""
    settings = settings or UKFSettings()
    table, evals = j_table(models, rec, horizon_s, settings, backend)
    qlpv = models.get("qlpv")
    bound = held_error_bound(qlpv, rec, horizon_s) if qlpv is not None else None
    val = Validation(rec, table, evals, reference_name(rec), settings, bound, identified_settings)
    if qlpv is None:
        return val
    if identified_settings is not None:
        idx, active, _ = active_ahead(qlpv, rec, horizon_s, identified_settings, backend)
        val.active_identified = j_of(active, reference(rec)[idx])
    runs: dict[str, FilterRun] = {}
    if sweep:  # the chapter filter's run is only read by the sweep
        runs["chapter"] = run_filter(qlpv, rec, settings, backend)
    if current_settings is not None and rec.psi_rad is not None:
        run = runs["current"] = run_filter(qlpv, rec, current_settings, backend)
        meas = reference(rec)
        idx, plain = predict_plain(qlpv, rec, run, horizon_s)
        _, active = predict_active(qlpv, rec, run, horizon_s)
        tail = slice(2 * len(rec) // 3, None)
        mean = run.current_ne[tail].mean(axis=0)
        std = float(np.sqrt(run.current_var[tail].mean(axis=0).max()))
        val.current_filter = CurrentFilterResult(
            current_settings, {"ahead": j_of(plain, meas[idx]), "ahead_active": j_of(active, meas[idx])},
            LogCurrent(float(mean[0]), float(mean[1]), std), float(run.weight[tail].mean()))
    if sweep:
        val.sweep = horizon_sweep(qlpv, rec, runs)
    return val


def ratios(table: JTable, model: str = "qlpv") -> dict[str, dict[str, float]]:
    """The chapter's Table 4 / Table 3 comparison: active 1-s-ahead J over the qLPV's J without
    model error (1 s ahead, and free run), per DOF."""
    row = table[model]
    return {base: {d: row["ahead_active"][d] / row[base][d] for d in DOF_NAMES}
            for base in ("ahead", "free_run")}


def format_table(table: JTable) -> str:
    """Plain-text J table (percent), models x prediction mode x DOF."""
    models = [m for m in MODEL_ORDER if m in table] + [m for m in table if m not in MODEL_ORDER]
    head = f"{'model':<28}" + "".join(f"{MODE_TITLES[m].split(',')[0][:16]:>22}" for m in MODES)
    sub = f"{'J (Eq. 12) in %':<28}" + "".join(f"{'u      v      r':>22}" for _ in MODES)
    lines = [head, sub]
    for m in models:
        cells = "".join("".join(f"{100 * table[m][mode][d]:7.2f}" for d in DOF_NAMES).rjust(22)
                        for mode in MODES)
        lines.append(f"{MODEL_TITLES.get(m, m):<28}{cells}")
    lines.append("modes: " + "; ".join(f"{m} = {t}" for m, t in MODE_TITLES.items()))
    return "\n".join(lines)


class ProgressBar:
    """A one-line text progress bar on stderr (only drawn when stderr is a terminal)."""

    def __init__(self, label: str, stream: TextIO | None = None, force: bool = False) -> None:
        self.label = label
        self.stream = stream or sys.stderr
        self.enabled = force or self.stream.isatty()
        self._last = -1

    def __call__(self, done: int, total: int) -> None:
        if not self.enabled or total <= 0:
            return
        pct = min(100, int(100 * done / total))
        if pct == self._last:
            return
        self._last = pct
        bar = "#" * (pct // 4)
        self.stream.write(f"\r{self.label} [{bar:<25}] {pct:3d}%")
        self.stream.flush()

    def close(self) -> None:
        if self.enabled and self._last >= 0:
            self.stream.write("\n")
            self.stream.flush()
