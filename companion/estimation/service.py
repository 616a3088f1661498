"""The active-model estimator as a synchronous control-loop stage (chapter Fig. 6).

``make_estimator_stage(ctx)`` loads the identified qLPV model (params.toml, see
:func:`companion.models.params_file.resolve_params_path`), builds the UKF the setting
``models.ukf`` names (the chapter's Eq. 5-11, or the current-augmented filter of
:mod:`companion.estimation.current_ukf`) computed by ``models.ukf_backend``, and returns
``stage(nav)``: every navigation sample it takes z = [u, v, r] and the heading from the
NavState and the input last applied (latest ``ActuatorCommand`` on the bus: throttle,
nozzle_rad), runs one predict+update, and publishes :class:`~companion.messages.ModelError` on
"model_error" and, with the current filter, :class:`~companion.messages.CurrentEstimate` on
"water_current".  A non-finite or out-of-order sample is skipped (logged once), never raised.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np

from companion.app import Context
from companion.estimation.current_ukf import current_filter_settings, current_mahalanobis, current_weight
from companion.estimation.ukf import UKF, UKFSettings, make_ukf
from companion.messages import ActuatorCommand, CurrentEstimate, ModelError, NavState
from companion.models.params_file import load_model_params, load_ukf_settings, resolve_params_path
from companion.models.qlpv import QLPVModel

log = logging.getLogger(__name__)

MAX_GAP_S = 0.5
"""A longer gap between samples re-initialises the filter from the measurement (Eq. 7)."""


def _params_path(ctx: Context) -> Path:
    try:
        configured = str(ctx.config["models.params_file"])
    except (KeyError, TypeError):
        configured = ""
    return resolve_params_path(Path(ctx.config.state_dir()), configured)


def load_companion_model(ctx: Context) -> QLPVModel:
    """The qLPV model the companion uses (configured path, state dir, or shipped default)."""
    path = _params_path(ctx)
    model = load_model_params(path)
    log.info("qLPV model parameters from %s", path)
    return model


def load_companion_ukf_settings(ctx: Context) -> UKFSettings:
    """The UKF the companion runs.  ``models.ukf`` "chapter" (default): Eq. 13's noise unless
    ``models.ukf_noise`` is "identified" and params.toml has a ``[ukf]`` table.  "current": the
    current-augmented filter with R from the sensor (params.toml's identified ``[ukf]`` R, else
    the GPS-INS of Table 2) and its own Q
    (:func:`~companion.estimation.current_ukf.current_filter_settings`)."""
    path = _params_path(ctx)
    if _setting(ctx, "models.ukf", "chapter") == "current":
        identified = load_ukf_settings(path)
        if identified is None:
            log.info("UKF with current states; R of the GPS-INS datasheet (Table 2)")
            return current_filter_settings()
        log.info("UKF with current states; R identified, from %s", path)
        return current_filter_settings(identified.r_diag)
    if _setting(ctx, "models.ukf_noise", "chapter") != "identified":
        return UKFSettings()
    settings = load_ukf_settings(path)
    if settings is None:
        log.warning("models.ukf_noise is 'identified' but %s has no [ukf] table; using Eq. 13", path)
        return UKFSettings()
    log.info("UKF noise identified, from %s", path)
    return settings


def _setting(ctx: Context, key: str, default: str) -> str:
    try:
        return str(ctx.config[key])
    except (KeyError, TypeError):
        return default


class EstimatorStage:
    """Callable stage ``(nav) -> None`` running the UKF on every navigation sample."""

    def __init__(self, ctx: Context, model: QLPVModel, settings: UKFSettings | None = None,
                 backend: str = "native") -> None:
        self.model = model
        self.settings = settings or UKFSettings()
        self.backend = backend
        self.ukf: UKF = make_ukf(model, self.settings, backend=backend)
        self._cmd = ctx.bus.topic("actuator_cmd", ActuatorCommand)
        self._out = ctx.bus.topic("model_error", ModelError)
        self._current = ctx.bus.topic("water_current", CurrentEstimate)
        self._t_last: float | None = None
        self._warned = False
        ctx.extras["qlpv_model"] = model

    def __call__(self, nav: NavState) -> None:
        z = np.array([nav.u_mps, nav.v_mps, nav.r_radps])
        needs_heading = self.ukf.n == 8
        if not (np.all(np.isfinite(z)) and math.isfinite(nav.t_s)
                and (math.isfinite(nav.heading_rad) or not needs_heading)):
            self._warn(f"non-finite navigation sample at t={nav.t_s}")
            return
        cmd = self._cmd.latest()
        thr = cmd.throttle if cmd is not None else 0.0
        nozzle = cmd.nozzle_rad if cmd is not None else 0.0
        if self._t_last is None or not 0.0 < nav.t_s - self._t_last <= MAX_GAP_S:
            if self._t_last is not None and nav.t_s <= self._t_last:
                self._warn(f"navigation time went from {self._t_last} to {nav.t_s}; filter restarted")
            self.ukf = make_ukf(self.model, self.settings, backend=self.backend)
            self.ukf.initialize(z)
        else:
            self.ukf.step(z, thr, nozzle, nav.t_s - self._t_last, nav.heading_rad)
        self._t_last = nav.t_s
        x, p = self.ukf.x, self.ukf.P
        self._out.publish(ModelError(nav.t_s, (float(x[3]), float(x[4]), float(x[5])),
                                     (float(p[3, 3]), float(p[4, 4]), float(p[5, 5])), float(self.ukf.nis)))
        if self.ukf.n == 8:
            cov = p[6:8, 6:8]
            self._current.publish(CurrentEstimate.from_components(
                nav.t_s, float(x[6]), float(x[7]), float(cov[0, 0]), float(cov[1, 1]),
                current_weight(current_mahalanobis(x[6:8], cov))))

    def _warn(self, text: str) -> None:
        if not self._warned:
            log.warning("estimator: %s", text)
            self._warned = True


def make_estimator_stage(ctx: Context) -> Callable[[NavState], None]:
    """The control-loop stage that estimates and publishes the model error delta_nu (and, with
    the current filter, the water current)."""
    return EstimatorStage(ctx, load_companion_model(ctx), load_companion_ukf_settings(ctx),
                          _setting(ctx, "models.ukf_backend", "native"))
