"""The active-model estimator as a synchronous control-loop stage (chapter Fig. 6).

``make_estimator_stage(ctx)`` loads the identified qLPV model (params.toml, see
:func:`companion.models.params_file.resolve_params_path`), builds the UKF of Eq. 5-11, and
returns ``stage(nav)``: every navigation sample it takes z = [u, v, r] from the NavState and
the input last applied (latest ``ActuatorCommand`` on the bus: throttle, nozzle_rad), runs
one predict+update, and publishes :class:`~companion.messages.ModelError` on "model_error".
A non-finite or out-of-order sample is skipped (logged once), never raised.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np

from companion.app import Context
from companion.estimation.ukf import UKF, UKFSettings, make_ukf
from companion.messages import ActuatorCommand, ModelError, NavState
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
    """The UKF noise the companion uses: the chapter's Eq. 13 unless the setting
    ``models.ukf_noise`` is "identified" and params.toml has a ``[ukf]`` table."""
    try:
        choice = str(ctx.config["models.ukf_noise"])
    except (KeyError, TypeError):
        choice = "chapter"
    if choice != "identified":
        return UKFSettings()
    path = _params_path(ctx)
    settings = load_ukf_settings(path)
    if settings is None:
        log.warning("models.ukf_noise is 'identified' but %s has no [ukf] table; using Eq. 13", path)
        return UKFSettings()
    log.info("UKF noise identified, from %s", path)
    return settings


class EstimatorStage:
    """Callable stage ``(nav) -> None`` running the UKF on every navigation sample."""

    def __init__(self, ctx: Context, model: QLPVModel, settings: UKFSettings | None = None) -> None:
        self.model = model
        self.settings = settings or UKFSettings()
        self.ukf: UKF = make_ukf(model, self.settings)
        self._cmd = ctx.bus.topic("actuator_cmd", ActuatorCommand)
        self._out = ctx.bus.topic("model_error", ModelError)
        self._t_last: float | None = None
        self._warned = False
        ctx.extras["qlpv_model"] = model

    def __call__(self, nav: NavState) -> None:
        z = np.array([nav.u_mps, nav.v_mps, nav.r_radps])
        if not (np.all(np.isfinite(z)) and math.isfinite(nav.t_s)):
            self._warn(f"non-finite navigation sample at t={nav.t_s}")
            return
        cmd = self._cmd.latest()
        thr = cmd.throttle if cmd is not None else 0.0
        nozzle = cmd.nozzle_rad if cmd is not None else 0.0
        if self._t_last is None or not 0.0 < nav.t_s - self._t_last <= MAX_GAP_S:
            if self._t_last is not None and nav.t_s <= self._t_last:
                self._warn(f"navigation time went from {self._t_last} to {nav.t_s}; filter restarted")
            self.ukf = make_ukf(self.model, self.settings)
            self.ukf.initialize(z)
        else:
            self.ukf.step(z, thr, nozzle, nav.t_s - self._t_last)
        self._t_last = nav.t_s
        d = self.ukf.x[3:]
        var = np.diag(self.ukf.P)[3:]
        self._out.publish(ModelError(nav.t_s, (float(d[0]), float(d[1]), float(d[2])),
                                     (float(var[0]), float(var[1]), float(var[2])), float(self.ukf.nis)))

    def _warn(self, text: str) -> None:
        if not self._warned:
            log.warning("estimator: %s", text)
            self._warned = True


def make_estimator_stage(ctx: Context) -> Callable[[NavState], None]:
    """The control-loop stage that estimates and publishes the model error delta_nu."""
    return EstimatorStage(ctx, load_companion_model(ctx), load_companion_ukf_settings(ctx))
