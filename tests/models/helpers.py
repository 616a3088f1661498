"""A plausible qLPV boat for unit tests (lumped parameters of the size a 2.8 m jet boat has)."""

from __future__ import annotations

import numpy as np

from companion.models.qlpv import QLPVModel


def reference_qlpv(c_thrust: float = 0.05) -> QLPVModel:
    th = np.zeros((3, len(QLPVModel.FEATURES)))
    f = QLPVModel.FEATURES

    def s(j: int, name: str, value: float) -> None:
        th[j, f.index(name)] = value

    s(0, "u", -0.25)
    s(0, "|u|u", -0.06)
    s(0, "vr", 0.6)
    s(0, "rr", 0.05)
    s(0, "Tcos", 30.0)
    s(1, "v", -1.2)
    s(1, "r", 0.15)
    s(1, "|v|v", -0.8)
    s(1, "|r|r", 0.05)
    s(1, "ur", -0.55)
    s(1, "Tsin", -3.0)
    s(2, "v", 0.3)
    s(2, "r", -1.4)
    s(2, "|v|v", 0.1)
    s(2, "|r|r", -0.6)
    s(2, "ur", 0.02)
    s(2, "Tsin", 9.0)
    return QLPVModel(th, name="reference", thrust_speed_coeff=c_thrust)


def sine_inputs(duration_s: float, dt_s: float = 0.01, throttle: float = 0.3, amp_rad: float = np.pi / 3,
                period_s: float = 12.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    t = np.arange(0.0, duration_s, dt_s)
    return t, np.full_like(t, throttle), amp_rad * np.sin(2 * np.pi * t / period_s)
