"""Physical constants of the simulated boat (chapter Table 1) and the derived matrices.

Every constant carries its unit.  The hull is a 2.8 m x 0.7 m fibre-reinforced
water-jet boat (chapter Table 1); the mass, inertia, added mass and damping values are
engineering estimates (strip theory for added mass, ITTC-1957 friction, a resistance
hump around the semi-displacement regime) chosen so that the measured behaviour meets
the chapter's figures: 36 km/h top speed at full throttle and a minimum turning radius
of about 1.375 m (Fig. 12).  They are *not* the chapter's qLPV parameters (Eq. 3-4),
which are identified from this plant's logs.

Payload (0..70 kg, Table 1) adds mass at ``payload_x_m`` forward of the centre and a
radius of gyration ``payload_gyration_m``, so it changes M (mass, inertia, x_G) and the
displacement-dependent resistance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

RHO_WATER_KGPM3 = 1000.0
RHO_AIR_KGPM3 = 1.225
GRAVITY_MPS2 = 9.81
KINEMATIC_VISCOSITY_M2PS = 1.19e-6

MAX_PAYLOAD_KG = 70.0


@dataclass(frozen=True, slots=True)
class BoatParams:
    """Constants of the simulated water-jet USV (SI units; Fossen's sign conventions)."""

    length_m: float = 2.8
    beam_m: float = 0.7
    draft_m: float = 0.15
    hull_mass_kg: float = 170.0
    payload_kg: float = 0.0
    payload_x_m: float = 0.2
    payload_gyration_m: float = 0.35
    hull_gyration_m: float = 0.7
    hull_xg_m: float = -0.15
    # added mass (strip theory, 2-D section added mass rho*pi*T^2 scaled by 0.7)
    x_udot_kg: float = -12.0
    y_vdot_kg: float = -138.0
    y_rdot_kgm: float = -12.0
    n_vdot_kgm: float = -12.0
    n_rdot_kgm2: float = -90.0
    # linear damping (dominant at low speed) and speed-proportional lift terms
    x_u_nspm: float = -8.0
    y_v_nspm: float = -150.0
    y_v_per_speed_nspm: float = -90.0
    n_r_nmsprad: float = -40.0
    n_r_per_speed_nmsprad: float = -25.0
    y_r_nsprad: float = -10.0
    n_v_nsm: float = -10.0
    n_v_per_speed_ns: float = 150.0  # keel and jet intake aft: weathercock stability at speed
    # cross-flow drag (strip theory, Fossen 2021 Sec. 6.7); the coefficient includes the keel,
    # spray strakes and jet intake that deepen the effective lateral profile beyond the draft
    crossflow_cd: float = 2.3
    # surge resistance: ITTC-57 friction on the wetted area + residual hump over Froude number
    wetted_area_m2: float = 1.6
    form_factor: float = 0.25
    hump_resistance_ratio: float = 0.11
    hump_froude: float = 0.9
    # planing: above Fr ~ 1 the hull rises, draft and wetted area shrink
    planing_draft_loss: float = 0.55
    planing_area_loss: float = 0.5
    # water jet (momentum theory: thrust = rho * A * Vj * (Vj - u))
    jet_area_m2: float = 0.00144
    jet_speed_max_mps: float = 20.0
    jet_x_m: float = -1.3
    engine_rpm_idle: float = 1200.0
    engine_rpm_max: float = 6500.0
    engine_tau_s: float = 0.4
    engine_stop_tau_s: float = 0.6
    engine_start_delay_s: float = 0.5
    nozzle_max_rad: float = math.pi / 3
    nozzle_rate_radps: float = math.radians(240.0)
    # wind exposure (Fossen 2021 Sec. 10.1): frontal/lateral projected areas and coefficients
    frontal_area_m2: float = 0.3
    lateral_area_m2: float = 0.95
    wind_cx: float = 0.7
    wind_cy: float = 0.9
    wind_cn: float = 0.1

    def with_payload(self, payload_kg: float) -> BoatParams:
        """The same boat carrying ``payload_kg`` (0..70 kg, chapter Table 1)."""
        if not 0.0 <= payload_kg <= MAX_PAYLOAD_KG:
            raise ValueError(f"payload {payload_kg} kg outside [0, {MAX_PAYLOAD_KG}] kg")
        return replace(self, payload_kg=payload_kg)

    @property
    def mass_kg(self) -> float:
        return self.hull_mass_kg + self.payload_kg

    @property
    def xg_m(self) -> float:
        return (self.hull_mass_kg * self.hull_xg_m + self.payload_kg * self.payload_x_m) / self.mass_kg

    @property
    def iz_kgm2(self) -> float:
        """Yaw inertia about the origin (midship), parallel-axis terms included."""
        hull = self.hull_mass_kg * (self.hull_gyration_m**2 + self.hull_xg_m**2)
        pay = self.payload_kg * (self.payload_gyration_m**2 + self.payload_x_m**2)
        return hull + pay

    def mass_matrix(self) -> np.ndarray:
        """M = M_RB + M_A (Fossen's notation), about the midship origin."""
        m, xg, iz = self.mass_kg, self.xg_m, self.iz_kgm2
        m_rb = np.array([[m, 0.0, 0.0], [0.0, m, m * xg], [0.0, m * xg, iz]])
        m_a = -np.array([[self.x_udot_kg, 0.0, 0.0],
                         [0.0, self.y_vdot_kg, self.y_rdot_kgm],
                         [0.0, self.n_vdot_kgm, self.n_rdot_kgm2]])
        return m_rb + m_a


@dataclass(frozen=True, slots=True)
class Derived:
    """Precomputed numbers the dynamics needs every step (floats, for fast scalar code)."""

    p: BoatParams
    minv: tuple[float, ...] = field(default=())
    mass_kg: float = 0.0
    xg_m: float = 0.0
    weight_n: float = 0.0
    inv_sqrt_gl: float = 0.0
    strips_x_m: tuple[float, ...] = ()
    strips_w_m: tuple[float, ...] = ()

    @staticmethod
    def of(p: BoatParams) -> Derived:
        minv = np.linalg.inv(p.mass_matrix())
        # 6-point Gauss-Legendre quadrature over the hull length for cross-flow drag
        g, w = np.polynomial.legendre.leggauss(6)
        half = p.length_m / 2.0
        # displacement grows with payload, and so does the wetted area (~ volume^(2/3))
        return Derived(
            p=p,
            minv=tuple(float(x) for x in minv.ravel()),
            mass_kg=p.mass_kg,
            xg_m=p.xg_m,
            weight_n=p.mass_kg * GRAVITY_MPS2,
            inv_sqrt_gl=1.0 / math.sqrt(GRAVITY_MPS2 * p.length_m),
            strips_x_m=tuple(float(x) for x in g * half),
            strips_w_m=tuple(float(x) for x in w * half),
        )

    @property
    def displacement_scale(self) -> float:
        """Wetted-area and draft scale (displacement ratio to the 2/3 and 1/3)."""
        return (self.mass_kg / self.p.hull_mass_kg) ** (1.0 / 3.0)
