"""Vehicle: pre-arm checks, home, modes and mission progress (unit tests on a plain context)."""

from __future__ import annotations

from companion.messages import STATUS_TEXT_TOPIC, FixType, ModeNumber
from companion.mission.items import MissionItem, MissionType
from companion.modes.base import Mode
from companion.modes.host import ModeHost
from companion.vehicle import MissionState
from tests.mavlink.helpers import HOME_LAT_DEG, make_ctx, make_vehicle, publish_nav


def test_arming_refused_without_position_then_accepted() -> None:
    ctx = make_ctx()
    vehicle = make_vehicle(ctx)
    texts: list[str] = []
    ctx.bus.topic(STATUS_TEXT_TOPIC).add_listener(lambda s: texts.append(s.text))
    reason = vehicle.arm()
    assert reason is not None and "navigation" in reason
    assert not vehicle.armed
    publish_nav(ctx, fix=FixType.NO_FIX, valid=False)
    assert "3D GPS fix" in (vehicle.arm() or "")
    publish_nav(ctx)
    assert vehicle.arm() is None
    assert vehicle.armed and "Armed" in texts
    assert vehicle.home is not None and abs(vehicle.home.lat_deg - HOME_LAT_DEG) < 1e-9
    assert vehicle.disarm() is None and not vehicle.armed


def test_stale_navigation_is_no_position() -> None:
    ctx = make_ctx()
    vehicle = make_vehicle(ctx)
    publish_nav(ctx)
    ctx.clock.advance_to(5.0)  # type: ignore[attr-defined]
    assert vehicle.nav() is None
    assert vehicle.arm() is not None


def test_force_arm_skips_checks() -> None:
    vehicle = make_vehicle(make_ctx())
    assert vehicle.arm(force=True) is None and vehicle.armed


def test_mode_change_refusal_and_listener() -> None:
    class NeedsMission(Mode):
        number = ModeNumber.AUTO
        name = "AUTO"

        def requirements(self, host: ModeHost) -> str | None:
            return None if len(host.mission.items()) > 1 else "no mission"

    ctx = make_ctx()
    from companion.modes.hold import HoldMode
    from companion.modes.manual import ManualMode
    vehicle = make_vehicle(ctx, [ManualMode, HoldMode, NeedsMission])
    assert vehicle.modes.current.name == "HOLD"
    assert vehicle.set_mode(10) == "AUTO: no mission"
    assert "unknown mode 99" in (vehicle.set_mode(99) or "")
    assert vehicle.set_mode(0) is None and vehicle.modes.current.name == "MANUAL"
    vehicle.missions.replace(MissionType.MISSION, [MissionItem.home(1, 2), MissionItem.waypoint(1, 1, 2)])
    assert vehicle.set_mode(10) is None


def test_failing_mode_update_falls_back_to_hold() -> None:
    class Broken(Mode):
        number = ModeNumber.GUIDED
        name = "GUIDED"

        def update(self, host: ModeHost, nav: object) -> None:
            raise ZeroDivisionError("boom")

    from companion.modes.hold import HoldMode
    ctx = make_ctx()
    vehicle = make_vehicle(ctx, [HoldMode, Broken])
    assert vehicle.set_mode(15) is None
    assert vehicle.update_mode(publish_nav(ctx)) is None  # no command from a broken mode
    assert vehicle.modes.current.name == "HOLD"


def test_mission_progress_states() -> None:
    ctx = make_ctx()
    vehicle = make_vehicle(ctx)
    assert vehicle.mission_state == MissionState.NO_MISSION
    plan = [MissionItem.home(41.77, 123.43)] + [MissionItem.waypoint(i, 41.77 + i * 1e-4, 123.43)
                                                for i in range(1, 4)]
    vehicle.missions.replace(MissionType.MISSION, plan)
    assert vehicle.mission_total == 3 and vehicle.current_seq == 1
    assert vehicle.mission_state == MissionState.NOT_STARTED
    assert vehicle.set_current(0) is None and vehicle.current_seq == 1  # home is never current
    assert vehicle.set_current(7) is not None
    reached: list[int] = []
    vehicle.reached_listeners.append(reached.append)
    vehicle.start_mission()
    vehicle.report_reached(1)
    assert reached == [1]
    assert vehicle.mission_state == MissionState.PAUSED
    vehicle.mission_complete()
    assert vehicle.mission_state == MissionState.COMPLETE
