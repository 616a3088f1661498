"""Closed-loop rig: the real simulated plant + UKF + a controller family, stepped at 100 Hz.

Used by the control benchmark (:mod:`benchmarks.control`) and by the closed-loop tests.  It
runs the same stages as the companion's control loop (navigation sample -> UKF model error ->
guidance -> controller -> actuator mapping -> plant) without the serial seam, so scenarios of
minutes run in seconds; the full seam is exercised by the SITL tests.  Navigation comes from the
plant's true over-ground state (the GPS-INS of chapter Table 2 is accurate to centimetres).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from companion.control.active_model import ActiveModelController
from companion.control.actuator import ActuatorMapper
from companion.control.params import (
    CTRL_ACTIVE_MODEL,
    active_model_config,
    actuator_limits,
    pid_config,
)
from companion.control.params import PARAMS as CONTROL_PARAMS
from companion.control.pid_family import PidController
from companion.control.target import ControlOutput, ControlTarget, CourseSpeedController
from companion.guidance.geo import LocalFrame
from companion.guidance.params import PARAMS as GUIDANCE_PARAMS
from companion.messages import NavState
from companion.models.qlpv import QLPVModel
from companion.models.ukf import make_ukf
from companion.params import ParamStore
from sim_bridge.disturbances import DisturbanceSpec
from sim_bridge.plant import BoatPlant

DT_S = 0.01
HOME = (41.77, 123.43)
"""Shenyang, where the chapter's boat was built (any origin works)."""


def control_params() -> ParamStore:
    """A store of the guidance and control parameters at their defaults."""
    return ParamStore(GUIDANCE_PARAMS + CONTROL_PARAMS)


@dataclass(frozen=True, slots=True)
class Environment:
    wind_mps: float = 0.0
    wind_from_deg: float = 0.0
    current_mps: float = 0.0
    current_toward_deg: float = 0.0
    waves_hs_m: float = 0.0
    seed: int = 1

    def spec(self) -> DisturbanceSpec:
        tp = max(1.0, 4.0 * math.sqrt(self.waves_hs_m)) if self.waves_hs_m > 0 else 0.0
        return DisturbanceSpec(wind_speed_mps=self.wind_mps, wind_from_rad=math.radians(self.wind_from_deg),
                               current_speed_mps=self.current_mps,
                               current_toward_rad=math.radians(self.current_toward_deg),
                               wave_hs_m=self.waves_hs_m, wave_tp_s=tp)


@dataclass
class Rig:
    """One boat under one controller family in one environment."""

    ctrl_type: int
    env: Environment
    model: QLPVModel
    psi0_rad: float = 0.0
    params: ParamStore = field(default_factory=lambda: control_params())

    def __post_init__(self) -> None:
        self.plant = BoatPlant(disturbances=self.env.spec(), seed=self.env.seed, psi0_rad=self.psi0_rad)
        self.frame = LocalFrame(*HOME)
        self.mapper = ActuatorMapper(actuator_limits(self.params))
        self.ukf = make_ukf(self.model)
        self._ukf_started = False
        self.delta_nu: tuple[float, float, float] = (0.0, 0.0, 0.0)
        self.controller: CourseSpeedController
        if self.ctrl_type == CTRL_ACTIVE_MODEL:
            self.controller = ActiveModelController(self.model, active_model_config(self.params),
                                                    delta_nu=lambda: self.delta_nu)
        else:
            self.controller = PidController(pid_config(self.params))
        self.nozzle_rad = 0.0
        self.throttle = 0.0
        self.last_output: ControlOutput | None = None

    @property
    def t_s(self) -> float:
        return self.plant.state.t_s

    def pos_ne(self) -> tuple[float, float]:
        return self.plant.state.north_m, self.plant.state.east_m

    def nav(self) -> NavState:
        s = self.plant.state
        lat, lon = self.frame.to_lat_lon(s.north_m, s.east_m)
        c, sn = math.cos(s.psi_rad), math.sin(s.psi_rad)
        return NavState(t_s=s.t_s, lat_deg=lat, lon_deg=lon, alt_m=0.0, heading_rad=s.psi_rad, roll_rad=0.0,
                        pitch_rad=0.0, vel_north_mps=s.u_mps * c - s.v_mps * sn,
                        vel_east_mps=s.u_mps * sn + s.v_mps * c, u_mps=s.u_mps, v_mps=s.v_mps,
                        r_radps=s.r_radps)

    def step(self, target: ControlTarget) -> NavState:
        """One 0.01 s control period; returns the navigation sample the controller used."""
        nav = self.nav()
        z = np.array([nav.u_mps, nav.v_mps, nav.r_radps])
        if not self._ukf_started:
            self.ukf.initialize(z)
            self._ukf_started = True
        else:
            dn = self.ukf.step(z, self.throttle, self.nozzle_rad, DT_S)
            self.delta_nu = (float(dn[0]), float(dn[1]), float(dn[2]))
        out = self.controller.update(nav, target, DT_S, self.mapper.saturation)
        self.last_output = out
        self.nozzle_rad, self.throttle, _ = self.mapper.apply(out.nozzle_rad, out.throttle, DT_S)
        self.plant.step(DT_S, self.nozzle_rad, self.throttle, True)
        return nav
