"""The active-model estimator stage of the 100 Hz pipeline (chapter Fig. 6).

:func:`load_companion_model` and :func:`load_companion_ukf_settings` read the identified qLPV
model and the UKF noise the companion flies (params.toml, see
:func:`companion.models.params_file.resolve_params_path`); :class:`EstimatorStage` runs the UKF
of Eq. 5-11 on them.  Every navigation sample, :meth:`EstimatorStage.step` takes
z = [u, v, r] from the NavState and the input last applied (the pipeline's previous
:class:`~companion.messages.ActuatorCommand`: throttle, nozzle_rad), runs one predict+update and
returns the :class:`~companion.messages.ModelError` estimate.  The setting ``models.ukf`` picks
the controller's filter: "chapter" (the default: Eq. 5-11 as published, on over-ground
velocities) or "current" (the current-augmented filter of :mod:`companion.models.current_ukf`
with the control tuning :func:`~companion.models.current_ukf.control_filter_settings`; its
delta_nu is the error of the model on the velocity through the water and travels with the
current it was estimated against, ``ModelError.water_ne_mps``, so the active-model law evaluates
the model there too, :attr:`EstimatorStage.water_relative`); ``models.ukf_backend`` picks who
computes it ("native" or the "filterpy" reference).  ``models.current_estimator`` "ukf" (the
default) runs the current-augmented filter with the prediction tuning
(:func:`~companion.models.current_ukf.current_filter_settings`, slow delta_nu) beside it: its
:class:`~companion.messages.CurrentEstimate` in :attr:`EstimatorStage.current` is what guidance
holds by and the ground station is told, with either filter for the controller (the control
filter's fast surge error takes up a current along the bow on a straight run).
A non-finite sample, or a second one with the time of the one before (a burst from the link),
is skipped (``None``); a sample from the past (logged once) or after a gap of more than
:data:`MAX_GAP_S` restarts the filters from its measurement.  Nothing raises.
"""

from __future__ import annotations

import logging
from math import isfinite
from pathlib import Path

import numpy as np

from companion.config import Config
from companion.messages import ActuatorCommand, CurrentEstimate, ModelError, NavState
from companion.models.current_ukf import control_filter_settings, current_filter_settings, current_weight
from companion.models.params_file import load_model_params, load_ukf_settings, resolve_params_path
from companion.models.qlpv import QLPVModel
from companion.models.ukf import UKF, UKFSettings, make_ukf

log = logging.getLogger(__name__)

MAX_GAP_S = 0.5
"""A longer gap between samples re-initialises the filter from the measurement (Eq. 7)."""


def _params_path(config: Config) -> Path:
    try:
        configured = str(config["models.params_file"])
    except (KeyError, TypeError):
        configured = ""
    return resolve_params_path(Path(config.state_dir()), configured)


def load_companion_model(config: Config) -> QLPVModel:
    """The qLPV model the companion uses (configured path, state dir, or shipped default)."""
    path = _params_path(config)
    model = load_model_params(path)
    log.info("qLPV model parameters from %s", path)
    return model


def load_companion_ukf_settings(config: Config) -> UKFSettings:
    """The UKF the controller flies on.  ``models.ukf`` "chapter" (default): Eq. 13's noise unless
    ``models.ukf_noise`` is "identified" and params.toml has a ``[ukf]`` table.  "current": the
    current-augmented filter with R from the sensor (params.toml's identified ``[ukf]`` R, else
    the GPS-INS of Table 2) and the control Q
    (:func:`~companion.models.current_ukf.control_filter_settings`)."""
    path = _params_path(config)
    if _setting(config, "models.ukf", "chapter") == "current":
        identified = load_ukf_settings(path)
        if identified is None:
            log.info("UKF with current states; R of the GPS-INS datasheet (Table 2)")
            return control_filter_settings()
        log.info("UKF with current states; R identified, from %s", path)
        return control_filter_settings(identified.r_diag)
    if _setting(config, "models.ukf_noise", "chapter") != "identified":
        return UKFSettings()
    settings = load_ukf_settings(path)
    if settings is None:
        log.warning("models.ukf_noise is 'identified' but %s has no [ukf] table; using Eq. 13", path)
        return UKFSettings()
    log.info("UKF noise identified, from %s", path)
    return settings


def load_companion_current_settings(config: Config) -> UKFSettings | None:
    """The current-augmented filter run beside the controller's for the current estimate
    (``models.current_estimator`` "ukf", the default; prediction tuning,
    :func:`~companion.models.current_ukf.current_filter_settings`), ``None`` when it is switched
    off ("none": the current then comes from the controller's filter if it estimates one)."""
    if _setting(config, "models.current_estimator", "ukf") != "ukf":
        return None
    identified = load_ukf_settings(_params_path(config))
    return current_filter_settings() if identified is None else current_filter_settings(identified.r_diag)


def load_companion_ukf_backend(config: Config) -> str:
    """Who computes the filter: "native" (numpy/numba) or "filterpy" (the reference)."""
    return _setting(config, "models.ukf_backend", "native")


def _setting(config: Config, key: str, default: str) -> str:
    try:
        return str(config[key])
    except (KeyError, TypeError):
        return default


def _current_estimate(t_s: float, x: np.ndarray, p: np.ndarray) -> CurrentEstimate:
    """The current states (6, 7) of a current-augmented filter as a :class:`CurrentEstimate`; the
    Mahalanobis distance of :func:`~companion.models.current_ukf.current_mahalanobis` in closed
    form for the 2 x 2 block (numpy's general solve cost ~100 us per sample, more than the filter)."""
    cn, ce = x.item(6), x.item(7)
    a, b, d = p.item(6, 6), p.item(6, 7), p.item(7, 7)
    det = a * d - b * b
    mahalanobis = (d * cn * cn - 2.0 * b * cn * ce + a * ce * ce) / det if det > 0.0 else 0.0
    return CurrentEstimate.from_components(t_s, cn, ce, a, d, current_weight(mahalanobis))


class EstimatorStage:
    """Runs the UKF on every navigation sample and returns the model error delta_nu."""

    def __init__(self, model: QLPVModel, settings: UKFSettings | None = None,
                 backend: str = "native", current_settings: UKFSettings | None = None) -> None:
        """``current_settings``: a current-augmented filter (``estimate_current``) run beside the
        controller's, for :attr:`current` only (without it, :attr:`current` is the controller's
        filter's own when that estimates the current)."""
        self.model = model
        self.settings = settings or UKFSettings()
        self.backend = backend
        self.ukf: UKF = make_ukf(model, self.settings, backend=backend)
        self.current_settings = current_settings
        self.current_ukf: UKF | None = None if self.current_settings is None else \
            make_ukf(model, self.current_settings, backend=backend)
        """The side filter that estimates the current beside the controller's (or ``None``)."""
        self.current: CurrentEstimate | None = None
        """The water current of the last step (a current-augmented filter only; else ``None``)."""
        self._t_last: float | None = None
        self._warned = False

    @property
    def water_relative(self) -> bool:
        """Whether delta_nu is the error of the model on the velocity through the water (the main
        filter is the current-augmented one; its model errors carry ``water_ne_mps``)."""
        return self.ukf.n == 8

    def warm_up(self) -> None:
        """Run a throwaway filter for two samples, so the compiled step is loaded (numba) now
        and not on the first navigation sample, where it stalls the 100 Hz loop for seconds
        (tests and benchmarks on the wall clock call this before feeding samples)."""
        for settings in (self.settings, self.current_settings):
            if settings is not None:
                ukf = make_ukf(self.model, settings, backend=self.backend)
                z = np.zeros(3)
                ukf.initialize(z)
                ukf.step(z, 0.0, 0.0, 0.01, 0.0)

    def step(self, nav: NavState, applied: ActuatorCommand | None) -> ModelError | None:
        """One predict+update for ``nav`` with the input ``applied`` since the last sample
        (``None``: nothing applied yet, throttle 0 and nozzle centred; ignition off: throttle 0)."""
        u_mps, v_mps, r_radps = nav.u_mps, nav.v_mps, nav.r_radps
        needs_heading = self.water_relative or self.current_ukf is not None
        # math.isfinite on the three floats: what np.all(np.isfinite(z)) says, at 1/40 of its cost
        if not (isfinite(u_mps) and isfinite(v_mps) and isfinite(r_radps) and isfinite(nav.t_s)
                and (isfinite(nav.heading_rad) or not needs_heading)):
            self._warn(f"non-finite navigation sample at t={nav.t_s}")
            return None
        if nav.t_s == self._t_last:
            # two samples handed over at one clock reading: a burst from the link (the simulator's
            # samples kept until the companion attached; sentences read from a serial port in one
            # go, on a clock coarser than the sample interval).  There is no interval to predict
            # over; the filters keep their state (restarting them here lost the current estimate)
            # and the next sample goes on from it.
            log.debug("estimator: a second navigation sample at t=%s skipped", nav.t_s)
            return None
        z = np.array((u_mps, v_mps, r_radps))
        # the engine's input: no thrust with the ignition off (a disarmed boat coasts and drifts
        # while its mode may still ask the controller for throttle; that thrust never happened)
        thr = applied.throttle if applied is not None and applied.ignition_on else 0.0
        nozzle = applied.nozzle_rad if applied is not None else 0.0
        if self._t_last is None or not 0.0 < nav.t_s - self._t_last <= MAX_GAP_S:
            if self._t_last is not None and nav.t_s <= self._t_last:
                self._warn(f"navigation time went from {self._t_last} to {nav.t_s}; filter restarted")
            self.ukf = make_ukf(self.model, self.settings, backend=self.backend)
            self.ukf.initialize(z)
            if self.current_settings is not None:
                self.current_ukf = make_ukf(self.model, self.current_settings, backend=self.backend)
                self.current_ukf.initialize(z)
        else:
            dt_s = nav.t_s - self._t_last
            self.ukf.step(z, thr, nozzle, dt_s, nav.heading_rad)
            if self.current_ukf is not None:
                self.current_ukf.step(z, thr, nozzle, dt_s, nav.heading_rad)
        self._t_last = nav.t_s
        current_filter = self.current_ukf if self.current_ukf is not None else \
            (self.ukf if self.water_relative else None)
        if current_filter is not None:
            self.current = _current_estimate(nav.t_s, current_filter.x, current_filter.P)
        x, p = self.ukf.x, self.ukf.P
        water_ne = (x.item(6), x.item(7)) if self.water_relative else None
        return ModelError(nav.t_s, (x.item(3), x.item(4), x.item(5)),
                          (p.item(3, 3), p.item(4, 4), p.item(5, 5)), float(self.ukf.nis), water_ne)

    def _warn(self, text: str) -> None:
        if not self._warned:
            log.warning("estimator: %s", text)
            self._warned = True
