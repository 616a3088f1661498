"""Reading and validating manoeuvre logs (the simulator's format, also used for real boat logs).

CSV with one header line.  Required columns: ``t`` (s, strictly increasing), ``u``, ``v``
(m/s, body frame), ``r`` (rad/s), ``throttle`` (0..1), ``delta`` (rad, nozzle angle,
positive to starboard).  Optional: ``psi`` (rad, heading clockwise from north: with it the
qLPV model is identified on water-relative velocities, a current estimated per log; see
:mod:`companion.models.current`), ``u_true``, ``v_true``, ``r_true``, ``psi_true`` (noiseless
truth from the simulator, used only for reporting), and any other columns (ignored).  Every problem
raises :class:`LogError` naming the file, the column and the row.
"""

from __future__ import annotations

import csv
import difflib
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from companion.models.base import FloatArray

REQUIRED_COLUMNS: tuple[str, ...] = ("t", "u", "v", "r", "throttle", "delta")
TRUTH_COLUMNS: tuple[str, ...] = ("u_true", "v_true", "r_true")
HEADING_COLUMN = "psi"
HEADING_TRUTH_COLUMN = "psi_true"


class LogError(ValueError):
    """A log cannot be used; the message names the file, column and row."""


@dataclass(frozen=True)
class Record:
    """One manoeuvre: time, measured nu = [u, v, r] (over ground), inputs, the heading when the
    log has it, and the truth when known."""

    name: str
    t_s: FloatArray
    nu: FloatArray
    throttle: FloatArray
    delta_rad: FloatArray
    nu_true: FloatArray | None = None
    psi_rad: FloatArray | None = None
    """Measured heading (rad, clockwise from north), if logged."""
    psi_true_rad: FloatArray | None = None
    """True heading (simulator logs), if logged."""

    @property
    def dt_s(self) -> float:
        return float(np.median(np.diff(self.t_s)))

    def __len__(self) -> int:
        return int(self.t_s.size)

    def slice(self, start: int, stop: int | None = None) -> Record:
        sl = slice(start, stop)
        return Record(self.name, self.t_s[sl], self.nu[sl], self.throttle[sl], self.delta_rad[sl],
                      None if self.nu_true is None else self.nu_true[sl],
                      None if self.psi_rad is None else self.psi_rad[sl],
                      None if self.psi_true_rad is None else self.psi_true_rad[sl])


def record_from_columns(columns: dict[str, FloatArray], name: str) -> Record:
    """Validate columns (same checks as :func:`read_log`) and build a :class:`Record`."""
    missing = [c for c in REQUIRED_COLUMNS if c not in columns]
    if missing:
        hints = []
        for c in missing:
            close = difflib.get_close_matches(c, list(columns), n=1, cutoff=0.5)
            hints.append(f"{c!r}" + (f" (found {close[0]!r}: misnamed?)" if close else ""))
        raise LogError(f"{name}: missing column(s) {', '.join(hints)}; "
                       f"required: {', '.join(REQUIRED_COLUMNS)}")
    wanted = (*REQUIRED_COLUMNS, *TRUTH_COLUMNS, HEADING_COLUMN, HEADING_TRUTH_COLUMN)
    cols = {c: np.asarray(columns[c], dtype=float) for c in wanted if c in columns}
    n = cols["t"].size
    if n < 10:
        raise LogError(f"{name}: only {n} data rows; a manoeuvre log needs many more")
    for c, values in cols.items():
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            rows = ", ".join(str(int(i) + 2) for i in bad[:5])
            raise LogError(f"{name}: column {c!r} has {bad.size} NaN/inf value(s), first at line(s) {rows}")
    dt = np.diff(cols["t"])
    bad = np.flatnonzero(dt <= 0)
    if bad.size:
        i = int(bad[0])
        raise LogError(f"{name}: time column 't' is not strictly increasing at line {i + 3} "
                       f"(t = {cols['t'][i]:g} then {cols['t'][i + 1]:g})")
    thr = cols["throttle"]
    if thr.min() < -1e-9 or thr.max() > 1 + 1e-9:
        raise LogError(f"{name}: column 'throttle' must be within 0..1 (found {thr.min():g}..{thr.max():g})")
    if np.abs(cols["delta"]).max() > math.pi:
        raise LogError(f"{name}: column 'delta' must be in radians (found |delta| up to "
                       f"{np.abs(cols['delta']).max():g}; degrees?)")
    for c in (HEADING_COLUMN, HEADING_TRUTH_COLUMN):
        if c in cols and np.abs(cols[c]).max() > 2.0 * math.pi + 0.1:
            raise LogError(f"{name}: column {c!r} must be in radians (found |{c}| up to "
                           f"{np.abs(cols[c]).max():g}; degrees?)")
    truth = None
    if all(c in cols for c in TRUTH_COLUMNS):
        truth = np.column_stack([cols[c] for c in TRUTH_COLUMNS])
    nu = np.column_stack([cols["u"], cols["v"], cols["r"]])
    return Record(name, cols["t"], nu, thr, cols["delta"], truth, cols.get(HEADING_COLUMN),
                  cols.get(HEADING_TRUTH_COLUMN))


def read_log(path: Path | str) -> Record:
    """Read and validate one CSV log."""
    path = Path(path)
    try:
        with path.open(newline="", encoding="utf-8") as fh:
            reader = csv.reader(fh)
            try:
                header = [h.strip() for h in next(reader)]
            except StopIteration:
                raise LogError(f"{path}: empty file (expected a CSV header line)") from None
            rows: list[list[float]] = []
            for lineno, row in enumerate(reader, start=2):
                if not row:
                    continue
                if len(row) != len(header):
                    raise LogError(f"{path}: line {lineno} has {len(row)} fields, "
                                   f"the header has {len(header)}")
                try:
                    rows.append([float(x) if x.strip() else math.nan for x in row])
                except ValueError:
                    raise LogError(f"{path}: line {lineno} has a non-numeric value: {row!r}") from None
    except OSError as exc:
        raise LogError(f"{path}: cannot read ({exc.strerror or exc})") from None
    data = np.array(rows, dtype=float).reshape(len(rows), len(header))
    return record_from_columns({h: data[:, j] for j, h in enumerate(header)}, str(path))
