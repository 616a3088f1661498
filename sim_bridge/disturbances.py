"""Wind, current and waves acting on the simulated boat, seeded and reproducible.

Conventions (the ``--wind``, ``--current`` and ``--waves`` flags):

* wind ``SPEED_MPS,FROM_DEG``: meteorological, the direction the wind blows FROM,
  clockwise from north.  Gusts are a first-order Gauss-Markov process on the speed
  (intensity ``gust_ratio`` of the mean, time constant ``gust_tau_s``).  Forces use
  Fossen's wind coefficients (Fossen 2021 Sec. 10.1):
  X = q C_X(gamma) A_F, Y = q C_Y(gamma) A_L, N = q C_N(gamma) A_L L, q = rho_air V_rw^2 / 2.
* current ``SPEED_MPS,TOWARD_DEG[,VAR]``: oceanographic, the direction the water flows
  TOWARD.  It enters through the relative velocity (irrotational current: the hull moves
  with the water).  ``VAR`` in [0, 1] (default 0: steady) makes it slowly varying: speed
  and direction are first-order Gauss-Markov processes around SPEED and TOWARD with
  standard deviations ``VAR * SPEED`` (m/s) and ``VAR`` (rad, i.e. ~57 deg x VAR) and a
  correlation time of ``CURRENT_TAU_S`` (minutes, like eddies in a flooded river).
* waves ``HS_M[,TP_S[,TOWARD_DEG]]``: a long-crested JONSWAP sea (gamma 3.3) as a sum of
  ``n_components`` sinusoids with seeded random phases.  First-order force: the hull
  slides down the local surface slope (Froude-Krylov, -m g grad(zeta), attenuated by
  e^{-k T}), evaluated at bow and stern for the yaw moment; second-order mean drift force
  0.5 rho g a^2 B R(k) in the direction of propagation.  Default Tp = 4 sqrt(Hs) s (min 1 s);
  default direction: downwind when a wind is given, else toward north.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from companion.config import ConfigError
from sim_bridge.hull import GRAVITY_MPS2, RHO_AIR_KGPM3, RHO_WATER_KGPM3, BoatParams
from sim_bridge.noise import NormalStream
from sim_bridge.plant_kernel import PAIRWISE_BLOCK
from sim_bridge.plant_kernel import wave_force as wave_force_kernel


@dataclass(frozen=True, slots=True)
class DisturbanceSpec:
    """What the flags asked for (all zero: calm water)."""

    wind_speed_mps: float = 0.0
    wind_from_rad: float = 0.0
    current_speed_mps: float = 0.0
    current_toward_rad: float = 0.0
    wave_hs_m: float = 0.0
    wave_tp_s: float = 0.0
    wave_toward_rad: float | None = None
    gust_ratio: float = 0.15
    gust_tau_s: float = 5.0
    current_var: float = 0.0
    """Relative variability of the current (0: steady), see the module docstring."""


CURRENT_TAU_S = 120.0
"""Correlation time of the slowly varying current (s)."""


def _numbers(flag: str, text: str, accepted: str, n_min: int, n_max: int) -> list[float]:
    parts = [p.strip() for p in str(text).split(",")]
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise ConfigError(f"{flag}: invalid value {text!r}; accepted: {accepted}") from None
    if not n_min <= len(values) <= n_max or not all(math.isfinite(v) for v in values):
        raise ConfigError(f"{flag}: invalid value {text!r}; accepted: {accepted}")
    return values


def parse_wind(text: str) -> tuple[float, float]:
    """``SPEED_MPS,FROM_DEG`` -> (speed m/s, from rad); raises ConfigError naming --wind."""
    accepted = "'SPEED_MPS,FROM_DEG' with speed in [0, 40] m/s, e.g. '5,270'"
    speed, from_deg = _numbers("--wind", text, accepted, 2, 2)
    if not 0.0 <= speed <= 40.0:
        raise ConfigError(f"--wind: speed {speed:g} m/s out of range; accepted: {accepted}")
    return speed, math.radians(from_deg % 360.0)


def parse_current(text: str) -> tuple[float, float]:
    """``SPEED_MPS,TOWARD_DEG[,VAR]`` -> (speed m/s, toward rad); raises ConfigError naming --current."""
    speed, toward, _var = parse_current_var(text)
    return speed, toward


def parse_current_var(text: str) -> tuple[float, float, float]:
    """``SPEED_MPS,TOWARD_DEG[,VAR]`` -> (speed m/s, toward rad, relative variability)."""
    accepted = ("'SPEED_MPS,TOWARD_DEG[,VAR]' with speed in [0, 5] m/s and VAR in [0, 1] "
                "(slowly varying; 0 steady), e.g. '0.5,90' or '0.5,90,0.2'")
    values = _numbers("--current", text, accepted, 2, 3)
    speed, toward_deg = values[0], values[1]
    if not 0.0 <= speed <= 5.0:
        raise ConfigError(f"--current: speed {speed:g} m/s out of range; accepted: {accepted}")
    var = values[2] if len(values) > 2 else 0.0
    if not 0.0 <= var <= 1.0:
        raise ConfigError(f"--current: VAR {var:g} out of range; accepted: {accepted}")
    return speed, math.radians(toward_deg % 360.0), var


def parse_waves(text: str) -> tuple[float, float, float | None]:
    """``HS_M[,TP_S[,TOWARD_DEG]]`` -> (Hs m, Tp s, toward rad or None)."""
    accepted = "'HS_M[,TP_S[,TOWARD_DEG]]' with Hs in [0, 2] m and Tp in [1, 20] s, e.g. '0.3,3'"
    values = _numbers("--waves", text, accepted, 1, 3)
    hs = values[0]
    if not 0.0 <= hs <= 2.0:
        raise ConfigError(f"--waves: height {hs:g} m out of range; accepted: {accepted}")
    tp = values[1] if len(values) > 1 else max(1.0, 4.0 * math.sqrt(hs))
    if hs > 0 and not 1.0 <= tp <= 20.0:
        raise ConfigError(f"--waves: period {tp:g} s out of range; accepted: {accepted}")
    toward = math.radians(values[2] % 360.0) if len(values) > 2 else None
    return hs, tp, toward


def spec_from_strings(wind: str = "0,0", current: str = "0,0", waves: str = "0") -> DisturbanceSpec:
    """Build a :class:`DisturbanceSpec` from the flag strings (validated)."""
    ws, wf = parse_wind(wind)
    cs, ct, cvar = parse_current_var(current)
    hs, tp, wt = parse_waves(waves)
    return DisturbanceSpec(ws, wf, cs, ct, hs, tp, wt, current_var=cvar)


def jonswap_components(hs_m: float, tp_s: float, n: int, rng: np.random.Generator
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Amplitudes (m), angular frequencies (rad/s) and phases of a JONSWAP sea (gamma 3.3)."""
    wp = 2.0 * math.pi / tp_s
    w = np.linspace(0.6 * wp, 3.0 * wp, n)
    dw = w[1] - w[0]
    sigma = np.where(w <= wp, 0.07, 0.09)
    gamma = 3.3 ** np.exp(-((w - wp) ** 2) / (2.0 * sigma**2 * wp**2))
    s_pm = (5.0 / 16.0) * hs_m**2 * wp**4 / w**5 * np.exp(-1.25 * (wp / w) ** 4)
    s = s_pm * gamma
    s *= (hs_m**2 / 16.0) / (np.sum(s) * dw)  # scale so that Hs = 4 sqrt(m0)
    amp = np.sqrt(2.0 * s * dw)
    phase = rng.uniform(0.0, 2.0 * math.pi, n)
    return amp, w, phase


class Environment:
    """Time-varying wind, current and wave field shared by every boat in a simulation."""

    def __init__(self, spec: DisturbanceSpec, params: BoatParams, seed: int, n_wave_components: int = 24
                 ) -> None:
        self.spec = spec
        self.p = params
        self.rng = np.random.default_rng([seed, 0x5eed])
        self.gust_mps = 0.0
        self.current_speed_dev_mps = 0.0
        self.current_dir_dev_rad = 0.0
        self.current_speed_mps = spec.current_speed_mps
        self.current_toward_rad = spec.current_toward_rad
        self.wind_speed_mps = spec.wind_speed_mps
        if spec.wave_hs_m > 0.0:
            amp, w, phase = jonswap_components(spec.wave_hs_m, spec.wave_tp_s, n_wave_components, self.rng)
        else:
            amp = w = phase = np.zeros(0)
        self.wave_amp_m, self.wave_w_radps, self.wave_phase = amp, w, phase
        self.wave_k_radpm = w**2 / GRAVITY_MPS2
        toward = spec.wave_toward_rad
        if toward is None:
            toward = (spec.wind_from_rad + math.pi) % (2 * math.pi) if spec.wind_speed_mps > 0 else 0.0
        self.wave_toward_rad = toward
        # mean drift force (N): 0.5 rho g a^2 B R(k), reflection R rising with k B
        refl = np.tanh(self.wave_k_radpm * params.beam_m)
        rho_g = RHO_WATER_KGPM3 * GRAVITY_MPS2
        self.wave_drift_n = float(np.sum(0.5 * rho_g * amp**2 * params.beam_m * refl))
        self.wave_attn = np.exp(-self.wave_k_radpm * params.draft_m)
        # per component, amplitude x wave number x attenuation: the slope's gain (precomputed, same floats)
        self._slope_gain = self.wave_amp_m * self.wave_k_radpm * self.wave_attn
        self._work = np.empty_like(self._slope_gain)
        self._compiled = 0 < self.wave_amp_m.size <= PAIRWISE_BLOCK
        self._noise = NormalStream(self.rng)  # the only draws after the wave phases above
        self.calm = spec.wind_speed_mps == 0.0 and spec.current_speed_mps == 0.0 and spec.wave_hs_m == 0.0
        """No wind, current or waves: the plant skips the external forces."""
        self._current_ned = self._current_ned_now()

    def advance(self, dt_s: float) -> None:
        """Advance the random processes (gusts, slowly varying current) by ``dt_s``."""
        s = self.spec
        if s.wind_speed_mps > 0.0:
            a = math.exp(-dt_s / s.gust_tau_s)
            sigma = s.gust_ratio * s.wind_speed_mps
            self.gust_mps = a * self.gust_mps + sigma * math.sqrt(1.0 - a * a) * self._noise.draw()
            self.wind_speed_mps = max(0.0, s.wind_speed_mps + self.gust_mps)
        if s.current_var > 0.0 and s.current_speed_mps > 0.0:
            a = math.exp(-dt_s / CURRENT_TAU_S)
            w = math.sqrt(1.0 - a * a)
            self.current_speed_dev_mps = a * self.current_speed_dev_mps + (
                s.current_var * s.current_speed_mps * w * self._noise.draw())
            self.current_dir_dev_rad = (a * self.current_dir_dev_rad
                                        + s.current_var * w * self._noise.draw())
            self.current_speed_mps = max(0.0, s.current_speed_mps + self.current_speed_dev_mps)
            self.current_toward_rad = s.current_toward_rad + self.current_dir_dev_rad
            self._current_ned = self._current_ned_now()

    def current_ned_mps(self) -> tuple[float, float]:
        """The current's north and east components (m/s), as of the last :meth:`advance`."""
        return self._current_ned

    def _current_ned_now(self) -> tuple[float, float]:
        c = self.current_speed_mps
        return c * math.cos(self.current_toward_rad), c * math.sin(self.current_toward_rad)

    def wind_force(self, psi: float, u_g: float, v_g: float) -> tuple[float, float, float]:
        """Wind force/moment on the hull (body frame) from the over-ground velocity."""
        vw = self.wind_speed_mps
        if vw == 0.0:
            return 0.0, 0.0, 0.0
        beta_to = self.spec.wind_from_rad + math.pi  # air moves toward this direction
        uw = vw * math.cos(beta_to - psi)
        vwb = vw * math.sin(beta_to - psi)
        u_rw, v_rw = u_g - uw, v_g - vwb
        gamma = math.atan2(v_rw, u_rw)  # angle of the relative air flow on the bow
        q = 0.5 * RHO_AIR_KGPM3 * (u_rw * u_rw + v_rw * v_rw)
        p = self.p
        return (-p.wind_cx * math.cos(gamma) * q * p.frontal_area_m2,
                -p.wind_cy * math.sin(gamma) * q * p.lateral_area_m2,
                -p.wind_cn * math.sin(2.0 * gamma) * q * p.lateral_area_m2 * p.length_m)

    def wave_force(self, t_s: float, x_n: float, y_e: float, psi: float, mass_kg: float
                   ) -> tuple[float, float, float]:
        """First-order slope force plus mean drift, body frame, at bow and stern points
        (compiled: :func:`sim_bridge.plant_kernel.wave_force`, bit-identical to
        :meth:`wave_force_reference`)."""
        if not self._compiled:
            return self.wave_force_reference(t_s, x_n, y_e, psi, mass_kg)
        return wave_force_kernel(t_s, x_n, y_e, psi, mass_kg, self.p.length_m / 4.0, self.wave_toward_rad,
                                 self._slope_gain, self.wave_w_radps, self.wave_k_radpm, self.wave_phase,
                                 self.wave_drift_n, GRAVITY_MPS2, self._work)

    def wave_force_reference(self, t_s: float, x_n: float, y_e: float, psi: float, mass_kg: float
                             ) -> tuple[float, float, float]:
        """:meth:`wave_force` written with numpy: the readable reference of the compiled one."""
        if self.wave_amp_m.size == 0:
            return 0.0, 0.0, 0.0
        cb, sb = math.cos(self.wave_toward_rad), math.sin(self.wave_toward_rad)
        cp, sp = math.cos(psi), math.sin(psi)
        quarter = self.p.length_m / 4.0
        fx_body = fy_body = fn = 0.0
        for sign in (1.0, -1.0):
            px = x_n + sign * quarter * cp
            py = y_e + sign * quarter * sp
            along = px * cb + py * sb
            theta = self.wave_w_radps * t_s - self.wave_k_radpm * along + self.wave_phase
            # d(zeta)/d(along) for zeta = sum a cos(theta)
            slope = float(np.sum(self.wave_amp_m * self.wave_k_radpm * self.wave_attn * np.sin(theta)))
            f_along = -0.5 * mass_kg * GRAVITY_MPS2 * slope
            fn_, fe_ = f_along * cb, f_along * sb
            fxb = cp * fn_ + sp * fe_
            fyb = -sp * fn_ + cp * fe_
            fx_body += fxb
            fy_body += fyb
            fn += sign * quarter * fyb
        drift = self.wave_drift_n
        fx_body += drift * math.cos(self.wave_toward_rad - psi)
        fy_body += drift * math.sin(self.wave_toward_rad - psi)
        return fx_body, fy_body, fn
