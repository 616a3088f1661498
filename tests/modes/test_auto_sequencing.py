"""AUTO's item sequencing, fast: the real vehicle (mode host), mission cursor, AUTO table and
control system, with navigation samples placed where a test wants the boat (no plant, no
estimator, no servo frame: the pipeline's modes and controller stages only).

The boat "sails" by being put on the point of the current item, so legs end at once and what
is tested is the order of items, the jumps, the waits and the turns, not the controller."""

from __future__ import annotations

import math

import pytest

from companion.control.target import ControlRequest
from companion.guidance.geo import LocalFrame
from companion.messages import STATUS_TEXT_TOPIC, ModeNumber, NavState
from companion.mission import items as mi
from companion.mission.items import MissionItem, MissionType
from companion.mission.validate import validate_plan
from companion.vehicle import MissionState, Vehicle
from tests.mavlink.helpers import HOME_LAT_DEG, HOME_LON_DEG, make_ctx, make_vehicle, publish_nav

FRAME = LocalFrame(HOME_LAT_DEG, HOME_LON_DEG)
DT_S = 0.1


class Rig:
    """A vehicle in AUTO and a clock; :meth:`sail` steps samples with the boat placed by a rule."""

    def __init__(self, items: list[tuple[int, tuple[float, float] | None, dict[str, float]]]) -> None:
        self.ctx = make_ctx()
        self.vehicle: Vehicle = make_vehicle(self.ctx)
        self.texts: list[str] = []
        self.ctx.bus.topic(STATUS_TEXT_TOPIC).add_listener(lambda s: self.texts.append(s.text))
        plan = [MissionItem.home(HOME_LAT_DEG, HOME_LON_DEG)]
        for seq, (cmd, ne, params) in enumerate(items, start=1):
            if ne is None:
                plan.append(MissionItem(seq=seq, frame=mi.FRAME_MISSION, command=cmd, **params))
            else:
                plan.append(MissionItem.at(seq, cmd, *FRAME.to_lat_lon(*ne), **params))
        assert validate_plan(plan, home_first=True) is None
        self.vehicle.missions.replace(MissionType.MISSION, plan)
        self.reached: list[tuple[int, float]] = []
        self.vehicle.reached_listeners.append(lambda seq: self.reached.append((seq, self.now_s)))
        self.vehicle.start_modes()
        self.sample(0.0, 0.0)
        assert self.vehicle.arm() is None
        assert self.vehicle.set_mode(ModeNumber.AUTO) is None

    @property
    def now_s(self) -> float:
        return self.ctx.clock.now_s()

    def sample(self, north_m: float, east_m: float) -> NavState:
        self.ctx.clock.advance_to(self.now_s + DT_S)  # type: ignore[attr-defined]
        lat_deg, lon_deg = FRAME.to_lat_lon(north_m, east_m)
        nav = publish_nav(self.ctx, lat_deg=lat_deg, lon_deg=lon_deg)
        request = self.vehicle.update_mode(nav)  # the pipeline's modes and controller stages
        if isinstance(request, ControlRequest):
            self.vehicle.control.apply(nav, request)
        return nav

    def at_current_item(self) -> tuple[float, float]:
        """Where the current item is (the boat's last position for items without one)."""
        item = self.vehicle.mission.item(self.vehicle.current_seq)
        if item is None or not item.is_global:
            return self.last
        return FRAME.to_ne(item.lat_deg, item.lon_deg)

    def sail(self, seconds: float, where: object = None) -> None:
        """Step ``seconds``; the boat is on the current item's point (or where ``where(t)`` says)."""
        for _ in range(round(seconds / DT_S)):
            if self.vehicle.modes.current.number != ModeNumber.AUTO:
                return
            self.last = where(self.now_s) if callable(where) else self.at_current_item()  # type: ignore[assignment]
            self.sample(*self.last)

    last: tuple[float, float] = (0.0, 0.0)

    def seqs(self) -> list[int]:
        return [seq for seq, _ in self.reached]


def test_do_jump_repeats_the_loop_then_carries_on() -> None:
    rig = Rig([(mi.CMD_NAV_WAYPOINT, (30.0, 0.0), {}),
               (mi.CMD_NAV_WAYPOINT, (30.0, 30.0), {}),
               (mi.CMD_DO_JUMP, None, {"param1": 1, "param2": 2}),
               (mi.CMD_NAV_WAYPOINT, (0.0, 30.0), {})])
    rig.sail(10.0)
    assert rig.seqs() == [1, 2, 1, 2, 1, 2, 4]
    assert rig.vehicle.mission_state == MissionState.COMPLETE
    assert rig.vehicle.modes.current.number == ModeNumber.HOLD  # MIS_DONE_BEHAVE 0


def test_a_jump_loop_without_navigation_stops_with_a_reason() -> None:
    rig = Rig([(mi.CMD_NAV_WAYPOINT, (30.0, 0.0), {}),
               (mi.CMD_DO_CHANGE_SPEED, None, {"param2": 2.0}),
               (mi.CMD_DO_JUMP, None, {"param1": 2, "param2": -1})])
    rig.sail(2.0)
    assert rig.seqs() == [1]
    assert "AUTO: too many jumps without a navigation item; stopping" in rig.texts
    assert rig.vehicle.mission_state == MissionState.COMPLETE


def test_condition_delay_waits_steering_as_before() -> None:
    rig = Rig([(mi.CMD_NAV_WAYPOINT, (20.0, 0.0), {}),
               (mi.CMD_CONDITION_DELAY, None, {"param1": 5.0}),
               (mi.CMD_NAV_WAYPOINT, (20.0, 20.0), {})])
    rig.sail(2.0)
    assert rig.seqs() == [1]
    auto = rig.vehicle.modes.current
    assert rig.vehicle.current_seq == 2 and auto.nav_target is not None  # still steering the last leg
    rig.sail(10.0)
    (_, t1), (seq3, t3) = rig.reached
    assert seq3 == 3 and 5.0 <= t3 - t1 <= 5.0 + 3 * DT_S


def test_nav_delay_keeps_station_for_its_time() -> None:
    rig = Rig([(mi.CMD_NAV_WAYPOINT, (10.0, 0.0), {}),
               (mi.CMD_NAV_DELAY, None, {"param1": 4.0}),
               (mi.CMD_NAV_WAYPOINT, (10.0, 10.0), {})])
    rig.sail(2.0)
    assert rig.vehicle.current_seq == 2
    target = rig.vehicle.modes.current.nav_target
    assert target is not None and target.speed_mps == pytest.approx(0.0, abs=1.0)  # station keeping
    rig.sail(10.0)
    (_, t1), (seq2, t2), (seq3, _) = rig.reached
    assert (seq2, seq3) == (2, 3) and 4.0 <= t2 - t1 <= 4.0 + 2 * DT_S


def test_waypoint_hold_time_keeps_station_before_going_on() -> None:
    rig = Rig([(mi.CMD_NAV_WAYPOINT, (10.0, 0.0), {"param1": 3.0}),
               (mi.CMD_NAV_WAYPOINT, (10.0, 10.0), {})])
    rig.sail(8.0)
    (_, t1), (_, t2) = rig.reached
    assert t1 >= 3.0 and t2 - t1 < 1.0


def _circle(radius_m: float, centre: tuple[float, float], period_s: float):
    def where(t_s: float) -> tuple[float, float]:
        angle = 2 * math.pi * t_s / period_s
        return centre[0] + radius_m * math.cos(angle), centre[1] + radius_m * math.sin(angle)
    return where


def test_loiter_turns_counts_turns_on_the_circle() -> None:
    centre = (20.0, 0.0)
    rig = Rig([(mi.CMD_NAV_LOITER_TURNS, centre, {"param1": 2.0, "param3": 10.0}),
               (mi.CMD_NAV_WAYPOINT, (0.0, 0.0), {})])
    rig.sail(1.0)  # on the point: within 15 m, the circle takes over
    assert rig.reached == []
    rig.sail(35.0, _circle(10.0, centre, period_s=20.0))  # 1.75 turns
    assert rig.reached == []
    rig.sail(8.0, _circle(10.0, centre, period_s=20.0))  # past 2 turns
    assert rig.seqs()[:1] == [1]


def test_loiter_turns_without_a_radius_keeps_station_a_minute_per_turn() -> None:
    rig = Rig([(mi.CMD_NAV_LOITER_TURNS, (10.0, 0.0), {"param1": 0.5}),
               (mi.CMD_NAV_WAYPOINT, (0.0, 0.0), {})])
    rig.sail(29.0)
    assert rig.reached == []
    rig.sail(3.0)
    assert rig.seqs()[:1] == [1] and 30.0 <= rig.reached[0][1] <= 32.0


def test_loiter_time_and_unlimited() -> None:
    rig = Rig([(mi.CMD_NAV_LOITER_TIME, (10.0, 0.0), {"param1": 6.0}),
               (mi.CMD_NAV_LOITER_UNLIM, (10.0, 10.0), {})])
    rig.sail(20.0)
    assert rig.seqs() == [1] and 6.0 <= rig.reached[0][1] <= 7.0
    rig.sail(100.0)
    assert rig.seqs() == [1] and rig.vehicle.modes.current.number == ModeNumber.AUTO  # for ever


def test_operator_jump_restarts_at_the_item_and_unknown_commands_are_skipped() -> None:
    rig = Rig([(mi.CMD_NAV_WAYPOINT, (10.0, 0.0), {"param1": 100.0}),
               (mi.CMD_DO_SET_SERVO, None, {"param1": 2, "param2": 1700}),
               (mi.CMD_USER_FIRST + 3, None, {}),
               (mi.CMD_NAV_WAYPOINT, (10.0, 10.0), {})])
    rig.sail(2.0)
    assert rig.reached == []  # holding at item 1 for 100 s
    assert rig.vehicle.set_current(2) is None
    rig.sail(2.0)
    assert rig.vehicle.servo_overrides_us == {2: 1700}
    assert any("command 31013 not supported; skipped" in t for t in rig.texts)
    assert rig.seqs() == [4] and rig.vehicle.mission_state == MissionState.COMPLETE
