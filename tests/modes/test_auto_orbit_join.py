"""AUTO entered on RTL's hold orbit joins the first leg as an aircraft leaves a holding pattern
(issue 14, ``USV_WP_JOIN``), fast: the real vehicle (mode manager, RTL, AUTO, control system) with
navigation samples placed on a circle round home (no plant).  What is tested is the decision:
keep circling while the bow is far off the leg, start the leg once it points along it; from rest
AUTO starts at once."""

from __future__ import annotations

import math

from companion.control.target import ControlRequest
from companion.guidance.geo import LocalFrame, wrap_pi
from companion.messages import NAV_TOPIC, STATUS_TEXT_TOPIC, CurrentEstimate, ModeNumber, NavState
from companion.mission import items as mi
from companion.mission.items import MissionItem, MissionType
from companion.modes.auto import AutoMode
from companion.modes.auto_items import Phase
from companion.modes.holding import OrbitTask
from companion.modes.orbit_join import MAX_WAIT_S
from companion.vehicle import Vehicle
from tests.mavlink.helpers import HOME_LAT_DEG, HOME_LON_DEG, make_ctx, make_vehicle

FRAME = LocalFrame(HOME_LAT_DEG, HOME_LON_DEG)
DT_S = 0.1
ORBIT_RADIUS_M = 2.0
ORBIT_RATE_RADPS = 0.5
"""1 m/s on a 2 m circle: RTL's hold orbit at USV_HOLD_ORB_SPD."""
LEG_END = (50.0, 0.0)
"""The first waypoint: due north of home."""


class OrbitRig:
    """A vehicle holding home on RTL's orbit in a weak current, the boat placed on the circle."""

    def __init__(self, join_deg: float = 20.0) -> None:
        self.ctx = make_ctx()
        self.ctx.params.set("USV_WP_JOIN", join_deg, persist=False)
        self.vehicle: Vehicle = make_vehicle(self.ctx)
        self.texts: list[str] = []
        self.ctx.bus.topic(STATUS_TEXT_TOPIC).add_listener(lambda s: self.texts.append(s.text))
        plan = [MissionItem.home(HOME_LAT_DEG, HOME_LON_DEG),
                MissionItem.at(1, mi.CMD_NAV_WAYPOINT, *FRAME.to_lat_lon(*LEG_END)),
                MissionItem.at(2, mi.CMD_NAV_WAYPOINT, *FRAME.to_lat_lon(50.0, 50.0))]
        self.vehicle.missions.replace(MissionType.MISSION, plan)
        self.vehicle.start_modes()
        self.bearing_rad = 0.0
        """Where the boat is on the circle (bearing from home)."""
        self.lam = 1.0
        self.sample_at_rest()
        assert self.vehicle.set_home(HOME_LAT_DEG, HOME_LON_DEG) is None
        assert self.vehicle.arm() is None

    def sample(self, north_m: float, east_m: float, heading_rad: float, speed_mps: float,
               r_radps: float, course_rad: float | None = None) -> NavState:
        """One navigation sample; the velocity along ``course_rad`` (the heading when None)."""
        ctx = self.ctx
        ctx.clock.advance_to(ctx.clock.now_s() + DT_S)  # type: ignore[attr-defined]
        now = ctx.clock.now_s()
        self.vehicle.control.use_current(CurrentEstimate.from_components(now, 0.05, 0.0, 0.001, 0.001, 0.9))
        lat_deg, lon_deg = FRAME.to_lat_lon(north_m, east_m)
        course = heading_rad if course_rad is None else course_rad
        nav = NavState(t_s=now, lat_deg=lat_deg, lon_deg=lon_deg, alt_m=0.0, heading_rad=heading_rad,
                       roll_rad=0.0, pitch_rad=0.0, vel_north_mps=speed_mps * math.cos(course),
                       vel_east_mps=speed_mps * math.sin(course), u_mps=speed_mps, v_mps=0.0,
                       r_radps=r_radps)
        ctx.bus.topic(NAV_TOPIC).publish(nav)
        request = self.vehicle.update_mode(nav)
        if isinstance(request, ControlRequest):
            self.vehicle.control.apply(nav, request)
        return nav

    def sample_at_rest(self) -> NavState:
        return self.sample(0.0, 0.0, 0.0, 0.0, 0.0)

    def hold_home_on_the_orbit(self) -> None:
        """RTL from home: it arrives at once and holds home on a drift-compensated orbit."""
        assert self.vehicle.set_mode(ModeNumber.RTL) is None
        for _ in range(2):  # the leg ends on its first step, the hold starts on the next
            self.sample(0.0, 0.0, 0.0, 1.0, 0.3)
        task = self.vehicle.modes.current.task  # type: ignore[attr-defined]
        assert isinstance(task, OrbitTask)
        self.lam = task.orbit.lam

    def circle(self, slip_deg: float = 0.0) -> NavState:
        """One sample on the circle round home, the orbit's way (course tangent to it), the bow
        ``slip_deg`` ahead of the course the orbit's way (the hull's slip in the turn)."""
        self.bearing_rad += self.lam * ORBIT_RATE_RADPS * DT_S
        course = self.bearing_rad + self.lam * 0.5 * math.pi
        r_m, rate = ORBIT_RADIUS_M, ORBIT_RATE_RADPS
        return self.sample(r_m * math.cos(self.bearing_rad), r_m * math.sin(self.bearing_rad),
                           course + self.lam * math.radians(slip_deg), r_m * rate, self.lam * rate, course)

    def place_for(self, off_deg: float, slip_deg: float = 0.0) -> None:
        """Put the boat on the circle where its course is ``off_deg`` short of due north (the
        first leg), measured the orbit's way."""
        self.bearing_rad = -self.lam * (math.radians(off_deg) + 0.5 * math.pi)
        self.circle(slip_deg)
        self.bearing_rad -= self.lam * ORBIT_RATE_RADPS * DT_S

    @property
    def auto(self) -> AutoMode:
        mode = self.vehicle.modes.current
        assert isinstance(mode, AutoMode)
        return mode

    def commanded_course_rad(self) -> float:
        target = self.vehicle.control.last_target
        assert target is not None
        return target.course_rad


def _leg_bearing_rad(nav: NavState) -> float:
    n, e = FRAME.to_ne(nav.lat_deg, nav.lon_deg)
    return math.atan2(LEG_END[1] - e, LEG_END[0] - n)


def _join(off_deg: float) -> tuple[OrbitRig, float, list[float]]:
    """Enter AUTO on the orbit ``off_deg`` short of the leg; circle until the leg starts.  The
    rig, the course's offset from the leg when it started (deg) and the commanded courses'
    offsets from the orbit's tangent while waiting (deg)."""
    rig = OrbitRig()
    rig.hold_home_on_the_orbit()
    for _ in range(20):
        rig.circle()
    rig.place_for(off_deg)
    assert rig.vehicle.set_mode(ModeNumber.AUTO) is None
    waiting: list[float] = []
    for _ in range(200):
        nav = rig.circle()
        if rig.auto.phase is not Phase.JOIN:
            return rig, math.degrees(wrap_pi(_leg_bearing_rad(nav) - nav.heading_rad)), waiting
        waiting.append(math.degrees(abs(wrap_pi(rig.commanded_course_rad() - nav.heading_rad))))
    raise AssertionError("AUTO never left the orbit")


def test_auto_on_the_orbit_90_deg_off_the_leg_keeps_circling_until_the_bow_points_along_it() -> None:
    rig, off_at_start_deg, waiting = _join(90.0)
    said = [t for t in rig.texts if t.startswith("AUTO: orbiting until the bow points along the first leg (")]
    assert len(said) == 1 and 85 <= int(said[0].split("(")[1].split()[0]) <= 92  # INFO: AUTO waits, and why
    assert 0.0 <= rig.lam * off_at_start_deg <= 21.0  # still turning toward the leg, within USV_WP_JOIN
    assert len(waiting) * DT_S >= 2.5  # a quarter orbit (pi/2 at 0.5 rad/s = 3.1 s) went by first
    assert max(waiting) < 60.0  # while waiting it steered the orbit, not the leg (90 deg off)
    assert rig.auto.phase is Phase.GOTO
    assert any("leaving the orbit onto the first leg" in t for t in rig.texts)
    here = rig.vehicle.nav()
    assert here is not None
    for _ in range(5):  # then the leg: the commanded course is the leg's, the speed the leg's
        nav = rig.sample(*FRAME.to_ne(here.lat_deg, here.lon_deg), 0.0, 2.0, 0.0)
    assert abs(math.degrees(wrap_pi(rig.commanded_course_rad() - _leg_bearing_rad(nav)))) < 10.0
    target = rig.vehicle.control.last_target
    assert target is not None and target.speed_mps > 1.5


def test_auto_on_the_orbit_heading_away_from_the_leg_waits_for_the_u_turn_round_the_orbit() -> None:
    rig, off_at_start_deg, waiting = _join(180.0)
    assert 0.0 <= rig.lam * off_at_start_deg <= 21.0
    assert 5.0 <= len(waiting) * DT_S <= 13.0  # half an orbit and more, never more than one orbit


def test_auto_on_the_orbit_already_pointing_along_the_leg_starts_at_once() -> None:
    rig = OrbitRig()
    rig.hold_home_on_the_orbit()
    rig.place_for(5.0)
    assert rig.vehicle.set_mode(ModeNumber.AUTO) is None
    assert rig.auto.phase is Phase.GOTO
    assert not any("orbiting until" in t for t in rig.texts)


def test_auto_on_the_orbit_with_the_bow_past_the_leg_keeps_circling_though_its_course_is_short() -> None:
    """On the orbit the bow leads the course by the hull's slip (25 deg at 1.8 m/s through the water
    in the simulator): with the course 5 deg short of the leg the bow is 20 deg past it, and the leg
    would have to reverse the orbit's turn (the boat swung 4.4 m off its first leg).  AUTO keeps
    circling, and leaves once course and bow both point short of the leg, within one orbit."""
    slip_deg = 25.0
    rig = OrbitRig(join_deg=70.0)
    rig.hold_home_on_the_orbit()
    for _ in range(20):
        rig.circle(slip_deg)
    rig.place_for(5.0, slip_deg)
    assert rig.vehicle.set_mode(ModeNumber.AUTO) is None
    assert rig.auto.phase is Phase.JOIN
    waited_s = 0.0
    nav = rig.circle(slip_deg)
    while rig.auto.phase is Phase.JOIN:
        assert waited_s < 20.0, "AUTO never left the orbit"
        nav = rig.circle(slip_deg)
        waited_s += DT_S
    bow_short_deg = rig.lam * math.degrees(wrap_pi(_leg_bearing_rad(nav) - nav.heading_rad))
    assert 0.0 <= bow_short_deg <= 70.0
    orbit_s = 2.0 * math.pi / ORBIT_RATE_RADPS
    assert 0.5 * orbit_s <= waited_s <= orbit_s


def test_auto_on_the_orbit_with_the_first_waypoint_beside_it_starts_at_once() -> None:
    """A first waypoint at the orbit's centre would never line up with the course: no wait."""
    rig = OrbitRig()
    home_wp = MissionItem.at(1, mi.CMD_NAV_WAYPOINT, HOME_LAT_DEG, HOME_LON_DEG)
    rig.vehicle.missions.replace(MissionType.MISSION, [MissionItem.home(HOME_LAT_DEG, HOME_LON_DEG), home_wp])
    rig.hold_home_on_the_orbit()
    rig.place_for(90.0)
    assert rig.vehicle.set_mode(ModeNumber.AUTO) is None
    assert rig.auto.phase is Phase.GOTO


def test_auto_from_rest_starts_the_leg_at_once() -> None:
    rig = OrbitRig()
    for _ in range(5):
        rig.sample(0.0, 0.0, math.pi, 0.0, 0.0)  # HOLD, bow south: the leg is behind it
    assert rig.vehicle.set_mode(ModeNumber.AUTO) is None
    assert rig.auto.phase is Phase.GOTO
    assert not any("orbiting until" in t for t in rig.texts)


def test_without_usv_wp_join_auto_leaves_the_orbit_at_once() -> None:
    rig = OrbitRig(join_deg=0.0)
    rig.hold_home_on_the_orbit()
    rig.place_for(90.0)
    assert rig.vehicle.set_mode(ModeNumber.AUTO) is None
    assert rig.auto.phase is Phase.GOTO


def test_auto_after_the_boat_drifted_off_the_orbit_starts_the_leg_at_once() -> None:
    """Disarmed in RTL the boat drifts off the orbit; armed again and put in AUTO it must not wait
    for a return to the orbit before the mission starts (found in the flood SITL search test)."""
    rig = OrbitRig()
    rig.hold_home_on_the_orbit()
    for _ in range(20):
        rig.circle()
    for _ in range(5):
        rig.sample(0.0, 15.0, math.pi, 0.5, 0.0)  # 15 m downstream, heading south, drifting
    assert rig.vehicle.set_mode(ModeNumber.AUTO) is None
    assert rig.auto.phase is Phase.GOTO
    assert not any("orbiting until" in t for t in rig.texts)


def test_the_wait_on_the_orbit_ends_after_max_wait_s_even_if_the_bow_never_lines_up() -> None:
    rig = OrbitRig()
    rig.hold_home_on_the_orbit()
    for _ in range(20):
        rig.circle()
    rig.place_for(180.0)
    assert rig.vehicle.set_mode(ModeNumber.AUTO) is None
    assert rig.auto.phase is Phase.JOIN
    waited_s = 0.0
    for _ in range(round((MAX_WAIT_S + 5.0) / DT_S)):  # the boat sits on the circle, bow away from the leg
        rig.sample(0.0, -2.0, math.pi, 0.0, 0.0)
        if rig.auto.phase is not Phase.JOIN:
            break
        waited_s += DT_S
    assert MAX_WAIT_S - 0.5 <= waited_s <= MAX_WAIT_S + 0.5, waited_s
    assert any(t.startswith("AUTO: leaving the orbit onto the first leg") for t in rig.texts)
