"""Open-loop manoeuvres on the simulated boat, logged for identification (``usv sim maneuver``).

Kinds (the boat starts at rest, engine running, and holds the throttle with the nozzle
centred for ``warmup_s`` before the manoeuvre; the log covers the whole run):

* ``sine``: nozzle = A sin(2 pi t / period), the chapter's identification input (Fig. 8:
  30 % throttle, A = pi/3);
* ``zigzag``: IMO zig-zag A/A: nozzle +-A, reversed when the heading change reaches +-A;
* ``turn``: constant nozzle A (turning circle);
* ``random``: nozzle uniform in [-A, A] and throttle within +-0.2 of ``throttle``, both held
  for random times around period/2 (persistent excitation for surge and steering).

Log format (CSV with one header line; see README "Log format"): ``t`` s, ``u``, ``v`` m/s
(body frame, over ground), ``r`` rad/s, ``throttle`` 0..1, ``delta`` rad (commanded nozzle,
positive to starboard), ``x``, ``y`` m (north, east), ``psi`` rad; the main columns are
GPS-INS measurements with Table 2 noise, ``*_true`` columns the noiseless truth
(``delta_true`` is the actual nozzle angle after the servo's rate limit), plus ``rpm``.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from companion.angles import wrap_pi
from companion.config import ConfigError
from sim_bridge.disturbances import spec_from_strings
from sim_bridge.gpsins import GpsInsModel
from sim_bridge.hull import BoatParams
from sim_bridge.plant import BoatPlant

KINDS = ("sine", "zigzag", "turn", "random")
COLUMNS = ("t", "u", "v", "r", "throttle", "delta", "x", "y", "psi",
           "u_true", "v_true", "r_true", "x_true", "y_true", "psi_true", "delta_true", "rpm")


@dataclass
class ManeuverLog:
    """Columns of a manoeuvre log (each a 1-D numpy array of equal length) and its settings."""

    columns: dict[str, np.ndarray]
    meta: dict[str, object] = field(default_factory=dict)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    def __len__(self) -> int:
        return len(self.columns["t"])


def run_maneuver(kind: str, *, throttle: float = 0.3, amplitude_rad: float = math.pi / 3,
                 period_s: float = 10.0, duration_s: float = 60.0, warmup_s: float = 10.0,
                 seed: int = 1, wind: str = "0,0", current: str = "0,0", waves: str = "0",
                 payload_kg: float = 0.0, dt_s: float = 0.01, rate_hz: int = 100) -> ManeuverLog:
    """Run an open-loop manoeuvre (see module docstring) and return its log."""
    if kind not in KINDS:
        raise ConfigError(f"maneuver: unknown kind {kind!r}; accepted: {', '.join(KINDS)}")
    if not 0.0 <= throttle <= 1.0:
        raise ConfigError(f"--throttle: {throttle:g} out of range; accepted: a number in [0, 1]")
    if not 0.0 < amplitude_rad <= math.pi / 2:
        raise ConfigError(f"--amplitude: {amplitude_rad:g} rad out of range; accepted: (0, pi/2] rad")
    if period_s <= 0.0 or duration_s <= 0.0 or warmup_s < 0.0:
        raise ConfigError("maneuver: --period and --duration must be > 0 and --warmup >= 0")
    params = BoatParams().with_payload(payload_kg)
    plant = BoatPlant(params, spec_from_strings(wind, current, waves), seed)
    sensor = GpsInsModel(seed, rate_hz=rate_hz)
    rng = np.random.default_rng([seed, 0xA11])
    n_steps = round((warmup_s + duration_s) / dt_s)
    rows: list[tuple[float, ...]] = []
    psi_ref: float | None = None
    zig_sign = 1.0
    rand_delta, rand_thr, rand_until = 0.0, throttle, 0.0
    meas = None
    for i in range(n_steps):
        t = i * dt_s
        s = plant.state
        if sensor.due(i, dt_s) or meas is None:
            meas = sensor.measure(s, dt_s)
        tm = t - warmup_s
        thr = throttle
        if tm < 0.0:
            delta = 0.0
        elif kind == "sine":
            delta = amplitude_rad * math.sin(2.0 * math.pi * tm / period_s)
        elif kind == "turn":
            delta = amplitude_rad
        elif kind == "zigzag":
            if psi_ref is None:
                psi_ref = s.psi_rad
            dpsi = wrap_pi(meas.psi_rad - psi_ref)
            if zig_sign > 0 and dpsi >= amplitude_rad:
                zig_sign = -1.0
            elif zig_sign < 0 and dpsi <= -amplitude_rad:
                zig_sign = 1.0
            delta = zig_sign * amplitude_rad
        else:
            if tm >= rand_until:
                rand_delta = float(rng.uniform(-amplitude_rad, amplitude_rad))
                rand_thr = float(np.clip(throttle + rng.uniform(-0.2, 0.2), 0.0, 1.0))
                rand_until = tm + float(rng.uniform(0.25, 0.75)) * period_s
            delta, thr = rand_delta, rand_thr
        rows.append((t, meas.u_mps, meas.v_mps, meas.r_radps, thr, delta, meas.north_m, meas.east_m,
                     meas.psi_rad, s.u_mps, s.v_mps, s.r_radps, s.north_m, s.east_m, s.psi_rad,
                     s.nozzle_rad, s.engine_rpm))
        plant.step(dt_s, delta, thr, True)
    data = np.array(rows)
    columns = {name: data[:, j] for j, name in enumerate(COLUMNS)}
    meta: dict[str, object] = {"kind": kind, "throttle": throttle, "amplitude_rad": amplitude_rad,
                               "period_s": period_s, "duration_s": duration_s, "warmup_s": warmup_s,
                               "seed": seed, "wind": wind, "current": current, "waves": waves,
                               "payload_kg": payload_kg}
    return ManeuverLog(columns, meta)


def write_log_csv(log: ManeuverLog, path: Path | str) -> None:
    """Write the log as CSV with a header line (columns in :data:`COLUMNS` order, then extras)."""
    names = [c for c in COLUMNS if c in log.columns] + [c for c in log.columns if c not in COLUMNS]
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(names)
        cols = [log.columns[n] for n in names]
        for row in zip(*cols, strict=True):
            w.writerow([f"{float(x):.6g}" for x in row])


def read_log_csv(path: Path | str) -> ManeuverLog:
    """Read a log written by :func:`write_log_csv` (or any CSV with the required columns)."""
    path = Path(path)
    try:
        with path.open(newline="", encoding="utf-8") as fh:
            reader = csv.reader(fh)
            header = next(reader)
            rows = [[float(x) for x in row] for row in reader if row]
    except (OSError, StopIteration, ValueError) as exc:
        raise ConfigError(f"{path}: not a readable manoeuvre log ({exc})") from None
    missing = [c for c in ("t", "u", "v", "r", "throttle", "delta") if c not in header]
    if missing:
        raise ConfigError(f"{path}: missing columns {', '.join(missing)}")
    data = np.array(rows, dtype=float).reshape(len(rows), len(header))
    return ManeuverLog({name: data[:, j] for j, name in enumerate(header)})
