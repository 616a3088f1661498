"""The simulated boat: 3-DOF hull dynamics, water-jet engine and nozzle servo, disturbances.

Conventions (Fossen's, and those of :mod:`companion.messages`):

* eta = [north_m, east_m, psi_rad]: position in a local NED frame at the start point,
  heading psi clockwise from north.
* nu = [u, v, r]: surge (m/s, forward), sway (m/s, positive to starboard), yaw rate
  (rad/s, positive clockwise seen from above).  :attr:`PlantState.u_mps` etc. are over
  the ground (what a GPS-INS measures); ``u_r_mps``/``v_r_mps`` are through the water.
* Inputs: ``nozzle_cmd_rad`` (positive = turn to starboard: psi increasing, r > 0;
  saturated at +-``nozzle_max_rad`` = pi/3 and rate limited by the servo),
  ``throttle_cmd`` 0..1 (engine speed set point, first-order engine lag), and
  ``ignition_on`` (engine off = no thrust; the engine starts after a short delay).
  No reverse bucket is modelled: the jet only pushes forward.

Integrator: classical RK4 at the 0.01 s step (see :func:`sim_bridge.dynamics.rk4_step`);
actuators are updated exactly (engine lag by its exponential, servo by its rate limit)
and held over the step.

:class:`BoatPlant` runs one boat through the compiled copy of those equations
(:func:`sim_bridge.plant_kernel.plant_step`, bit-identical, a few microseconds a step);
:class:`BatchPlant` steps N boats as numpy arrays with :func:`~sim_bridge.dynamics.nu_dot` itself.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sim_bridge.disturbances import DisturbanceSpec, Environment
from sim_bridge.dynamics import VECTOR, rk4_step
from sim_bridge.hull import BoatParams, Derived
from sim_bridge.plant_kernel import hull_constants, plant_step


@dataclass(slots=True)
class PlantState:
    """True state of one boat (mutable, updated in place by :meth:`BoatPlant.step`)."""

    t_s: float = 0.0
    north_m: float = 0.0
    east_m: float = 0.0
    psi_rad: float = 0.0
    u_r_mps: float = 0.0
    v_r_mps: float = 0.0
    r_radps: float = 0.0
    u_mps: float = 0.0
    v_mps: float = 0.0
    u_dot_mps2: float = 0.0
    v_dot_mps2: float = 0.0
    engine_rpm: float = 0.0
    engine_running: bool = False
    nozzle_rad: float = 0.0
    thrust_n: float = 0.0

    @property
    def eta(self) -> tuple[float, float, float]:
        return (self.north_m, self.east_m, self.psi_rad)

    @property
    def nu(self) -> tuple[float, float, float]:
        return (self.u_mps, self.v_mps, self.r_radps)

    @property
    def speed_mps(self) -> float:
        return math.hypot(self.u_mps, self.v_mps)


class Engine:
    """Ignition, start delay and first-order engine-speed lag (exact discretisation)."""

    def __init__(self, p: BoatParams) -> None:
        self.p = p
        self.rpm = 0.0
        self.running = False
        self._crank_s = 0.0

    def step(self, dt_s: float, throttle: float, ignition_on: bool) -> float:
        p = self.p
        if ignition_on and not self.running:
            self._crank_s += dt_s
            if self._crank_s >= p.engine_start_delay_s:
                self.running = True
        elif not ignition_on:
            self.running = False
            self._crank_s = 0.0
        if self.running:
            thr = min(1.0, max(0.0, throttle))
            target = p.engine_rpm_idle + thr * (p.engine_rpm_max - p.engine_rpm_idle)
            tau = p.engine_tau_s
        else:
            target, tau = 0.0, p.engine_stop_tau_s
        self.rpm += (target - self.rpm) * (1.0 - math.exp(-dt_s / tau))
        if not self.running and self.rpm < 1.0:
            self.rpm = 0.0
        return self.rpm


def servo_step(angle_rad: float, cmd_rad: float, dt_s: float, p: BoatParams) -> float:
    """Nozzle servo: saturate the command, then move toward it at the rate limit."""
    target = min(p.nozzle_max_rad, max(-p.nozzle_max_rad, cmd_rad))
    step = p.nozzle_rate_radps * dt_s
    return angle_rad + min(step, max(-step, target - angle_rad))


class BoatPlant:
    """One simulated boat.  ``step`` advances ``dt_s`` with the given actuator commands."""

    def __init__(self, params: BoatParams | None = None, disturbances: DisturbanceSpec | None = None,
                 seed: int = 1, *, psi0_rad: float = 0.0, environment: Environment | None = None) -> None:
        self.params = params or BoatParams()
        self.derived = Derived.of(self.params)
        self._hull = hull_constants(self.derived)
        self.env = environment or Environment(disturbances or DisturbanceSpec(), self.params, seed)
        self.engine = Engine(self.params)
        self.state = PlantState(psi_rad=psi0_rad)

    def step(self, dt_s: float, nozzle_cmd_rad: float, throttle_cmd: float, ignition_on: bool) -> None:
        s, p = self.state, self.params
        rpm = self.engine.step(dt_s, throttle_cmd, ignition_on)
        s.nozzle_rad = servo_step(s.nozzle_rad, nozzle_cmd_rad, dt_s, p)
        jet_speed = p.jet_speed_max_mps * rpm / p.engine_rpm_max
        env = self.env
        env.advance(dt_s)
        cn, ce = env.current_ned_mps()
        if env.calm:
            tau = (0.0, 0.0, 0.0)
        else:
            wx, wy, wn = env.wind_force(s.psi_rad, s.u_mps, s.v_mps)
            ax, ay, an = env.wave_force(s.t_s, s.north_m, s.east_m, s.psi_rad, self.derived.mass_kg)
            tau = (wx + ax, wy + ay, wn + an)
        (s.north_m, s.east_m, s.psi_rad, s.u_r_mps, s.v_r_mps, s.r_radps, s.u_dot_mps2, s.v_dot_mps2,
         s.u_mps, s.v_mps, s.thrust_n) = plant_step(s.north_m, s.east_m, s.psi_rad, s.u_r_mps, s.v_r_mps,
                                                    s.r_radps, dt_s, jet_speed, s.nozzle_rad, tau[0], tau[1],
                                                    tau[2], cn, ce, self._hull)
        s.t_s += dt_s
        s.engine_rpm, s.engine_running = rpm, self.engine.running

    def kinetic_energy_j(self) -> float:
        """0.5 nu_r^T M nu_r: the hull's kinetic energy (rigid body plus added mass)."""
        nu = np.array([self.state.u_r_mps, self.state.v_r_mps, self.state.r_radps])
        return float(0.5 * nu @ self.params.mass_matrix() @ nu)


class BatchPlant:
    """N boats stepped together as numpy arrays (same hull, same environment field).

    Disturbances here are the current only (wind and waves would need per-boat force
    evaluation; use :class:`BoatPlant` for those).  Arrays have shape (N,).
    ``current_ned_mps``: a steady current per boat (north and east arrays, m/s) instead of the
    environment's one field (campaigns step boats in different currents together).
    """

    def __init__(self, n: int, params: BoatParams | None = None, disturbances: DisturbanceSpec | None = None,
                 seed: int = 1, *, current_ned_mps: tuple[np.ndarray, np.ndarray] | None = None) -> None:
        self.n = n
        self.current_ned_mps = current_ned_mps
        self.params = params or BoatParams()
        self.derived = Derived.of(self.params)
        self.env = Environment(disturbances or DisturbanceSpec(), self.params, seed)
        z = np.zeros(n)
        self.t_s = 0.0
        self.north_m, self.east_m, self.psi_rad = z.copy(), z.copy(), z.copy()
        self.u_r_mps, self.v_r_mps, self.r_radps = z.copy(), z.copy(), z.copy()
        self.engine_rpm, self.nozzle_rad = z.copy(), z.copy()
        self._crank_s = z.copy()
        self.running = np.zeros(n, dtype=bool)

    def step(self, dt_s: float, nozzle_cmd_rad: np.ndarray | float, throttle_cmd: np.ndarray | float,
             ignition_on: np.ndarray | bool) -> None:
        p = self.params
        ign = np.broadcast_to(np.asarray(ignition_on, dtype=bool), (self.n,))
        self._crank_s = np.where(ign & ~self.running, self._crank_s + dt_s, np.where(ign, self._crank_s, 0.0))
        self.running = ign & (self.running | (self._crank_s >= p.engine_start_delay_s))
        thr = np.clip(throttle_cmd, 0.0, 1.0)
        target = np.where(self.running, p.engine_rpm_idle + thr * (p.engine_rpm_max - p.engine_rpm_idle), 0.0)
        tau = np.where(self.running, p.engine_tau_s, p.engine_stop_tau_s)
        self.engine_rpm += (target - self.engine_rpm) * (1.0 - np.exp(-dt_s / tau))
        cmd = np.clip(nozzle_cmd_rad, -p.nozzle_max_rad, p.nozzle_max_rad)
        lim = p.nozzle_rate_radps * dt_s
        self.nozzle_rad += np.clip(cmd - self.nozzle_rad, -lim, lim)
        jet_speed = p.jet_speed_max_mps * self.engine_rpm / p.engine_rpm_max
        self.env.advance(dt_s)
        cn, ce = self.env.current_ned_mps() if self.current_ned_mps is None else self.current_ned_mps
        out = rk4_step(self.north_m, self.east_m, self.psi_rad, self.u_r_mps, self.v_r_mps, self.r_radps,
                       dt_s, jet_speed, self.nozzle_rad, (0.0, 0.0, 0.0), cn, ce, self.derived, VECTOR)
        self.north_m, self.east_m, psi, self.u_r_mps, self.v_r_mps, self.r_radps = out
        self.psi_rad = np.mod(psi, 2.0 * math.pi)
        self.t_s += dt_s
