"""The mode registry and the switch between modes.

:data:`MODE_CLASSES` is the only place modes are listed: adding a mode is one file in
``companion/modes/``, one line here and one test.  :class:`ModeManager` owns one instance
of each, checks a mode's requirements before entering it (refusals come back as a reason
for the operator), runs ``exit``/``enter`` in order and calls the active mode's ``update``
from the pipeline.  Modes run against a :class:`~companion.modes.host.ModeHost` given with
each call (the vehicle).  A mode that raises in ``update`` is replaced by HOLD so the boat
stops instead of running with a broken mode.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

from companion.guidance.current import CurrentObserver
from companion.messages import ModeNumber, NavState, Severity
from companion.modes.auto import AutoMode
from companion.modes.base import Mode, ModeOutput
from companion.modes.cruise import CruiseMode
from companion.modes.guided import GuidedMode
from companion.modes.hold import HoldMode
from companion.modes.host import ModeHost
from companion.modes.loiter import LoiterMode
from companion.modes.manual import ManualMode
from companion.modes.navigation import NavMode
from companion.modes.rtl import RtlMode

log = logging.getLogger(__name__)

MODE_CLASSES: list[type[Mode]] = [
    ManualMode,
    HoldMode,
    LoiterMode,
    AutoMode,
    RtlMode,
    GuidedMode,
    CruiseMode,
]
"""Every mode of the vehicle (one line per mode)."""

INITIAL_MODE_NUMBER = ModeNumber.HOLD
"""The boat boots in HOLD: engine idle, nozzle centred (it drifts)."""

FALLBACK_MODE_NUMBER = ModeNumber.HOLD
"""Where the manager goes when a mode fails."""

ModeListener = Callable[[Mode, Mode], None]


class ModeManager:
    """One instance of each registered mode and the currently active one."""

    def __init__(self, classes: list[type[Mode]] | None = None) -> None:
        self._modes: dict[int, Mode] = {}
        for cls in classes if classes is not None else MODE_CLASSES:
            mode = cls()
            if mode.number in self._modes:
                other = self._modes[mode.number]
                raise ValueError(f"mode number {mode.number} used by {other!r} and {mode!r}")
            self._modes[mode.number] = mode
        initial = self._modes.get(INITIAL_MODE_NUMBER) or next(iter(self._modes.values()))
        self._current = initial
        self._listeners: list[ModeListener] = []
        self._entered = False
        self.drift = CurrentObserver()
        """The water current seen from over-ground velocity and heading, learnt in every mode and
        shared by the navigating modes (crab feed-forward, :mod:`companion.guidance.current`)."""
        self._drift_t_s: float | None = None
        for m in self._modes.values():
            if isinstance(m, NavMode):
                m.drift = self.drift

    @property
    def current(self) -> Mode:
        """The active mode."""
        return self._current

    def start(self, host: ModeHost) -> None:
        """Enter the initial mode (called once the vehicle is wired)."""
        if not self._entered:
            self._entered = True
            self._current.enter(host)

    def available(self) -> list[Mode]:
        """Every registered mode, ordered by number (AVAILABLE_MODES order)."""
        return [self._modes[n] for n in sorted(self._modes)]

    def get(self, number: int) -> Mode | None:
        return self._modes.get(number)

    def by_name(self, name: str) -> Mode | None:
        wanted = name.strip().upper()
        return next((m for m in self._modes.values() if m.name == wanted), None)

    def by_standard_mode(self, standard_mode: int) -> Mode | None:
        return next((m for m in self.available() if m.standard_mode == standard_mode), None)

    def add_listener(self, listener: ModeListener) -> None:
        """``listener(old, new)`` runs after every successful mode change."""
        self._listeners.append(listener)

    def set_mode(self, number: int, host: ModeHost) -> str | None:
        """Switch to mode ``number``; ``None`` when accepted, otherwise the reason for refusal."""
        mode = self._modes.get(int(number)) if float(number).is_integer() else None
        if mode is None:
            known = ", ".join(f"{m.name}={m.number}" for m in self.available())
            return f"unknown mode {number:g} (modes: {known})"
        if mode is self._current and self._entered:
            return None
        try:
            reason = mode.requirements(host)
        except Exception as exc:
            log.exception("requirements() of %r failed", mode)
            reason = f"{mode.name} check failed: {exc}"
        if reason:
            return f"{mode.name}: {reason}"
        return self._switch(mode, host)

    def _switch(self, mode: Mode, host: ModeHost) -> str | None:
        old = self._current
        if self._entered:
            try:
                old.exit(host)
            except Exception:
                log.exception("exit() of %r failed", old)
        if isinstance(mode, NavMode):
            mode.handed_over = old.task if isinstance(old, NavMode) and self._entered else None
        try:
            mode.enter(host)
        except Exception as exc:
            log.exception("enter() of %r failed", mode)
            try:
                old.enter(host)
            except Exception:
                log.exception("re-entering %r failed", old)
            return f"{mode.name}: could not start ({exc})"
        self._entered = True
        self._current = mode
        for listener in tuple(self._listeners):
            try:
                listener(old, mode)
            except Exception:
                log.exception("mode listener failed")
        return None

    def update(self, host: ModeHost, nav: NavState) -> ModeOutput:
        """Run the active mode for one navigation sample (the pipeline's modes stage): what it
        asks of the controller, ``None`` when nothing new this sample (the last command stays)."""
        mode = self._current
        if self._drift_t_s is not None:
            self.drift.update(nav.vel_north_mps, nav.vel_east_mps, nav.heading_rad, nav.r_radps,
                              min(1.0, nav.t_s - self._drift_t_s))
        self._drift_t_s = nav.t_s
        try:
            return mode.update(host, nav)
        except Exception as exc:
            log.exception("update() of %r failed", mode)
            self.fall_back(host, exc)
            return None

    def fall_back(self, host: ModeHost, exc: Exception) -> None:
        """The active mode failed (its update, or the controller on its request): go to HOLD."""
        mode = self._current
        fallback = self._modes.get(FALLBACK_MODE_NUMBER)
        if fallback is not None and fallback is not mode:
            host.status(f"{mode.name} failed ({exc}); switching to {fallback.name}", Severity.CRITICAL)
            self._switch(fallback, host)
