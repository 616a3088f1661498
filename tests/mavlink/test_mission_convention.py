"""Item 0 of a mission: ArduPilot's home placeholder (QGC, MAVProxy) or the first waypoint (MAVSDK).

The rule (:func:`companion.mission.convention.classify`) on hand-made plans shaped like each
client's, then over MAVLink: each client downloads the shape it uploaded, MISSION_CURRENT
counts the items the boat will execute, and an ambiguous upload is refused loudly and keeps
the old plan.
"""

from __future__ import annotations

import asyncio
import json
import math
from pathlib import Path

import pytest

from companion.guidance.geo import LocalFrame
from companion.link.dialect import mav
from companion.messages import STATUS_TEXT_TOPIC
from companion.mission import items as mi
from companion.mission.convention import HOME_MATCH_M, Convention, classify
from companion.mission.items import MissionItem, MissionType
from companion.mission.store import MissionStore
from tests.mavlink.gcs import AsyncGcs, free_port
from tests.mavlink.helpers import HOME_LAT_DEG, HOME_LON_DEG, publish_nav, running_vehicle
from tests.mavlink.test_params_missions import download, upload

HOME = (HOME_LAT_DEG, HOME_LON_DEG)
NAN = math.nan


def _e7(deg: float) -> int:
    return round(deg * 1e7)


def _wp(seq: int, north_m: float, frame: int = mi.FRAME_GLOBAL_RELATIVE_ALT_INT, *, current: int = 0,
        hold_s: float = 0.0, accept_m: float = 0.0) -> MissionItem:
    lat, _ = LocalFrame(*HOME).to_lat_lon(north_m, 0.0)
    return MissionItem(seq=seq, frame=frame, command=mi.CMD_NAV_WAYPOINT, param1=hold_s, param2=accept_m,
                       param4=NAN, x=_e7(lat), y=_e7(HOME[1]), current=current)


def mavsdk_plan(n: int) -> list[MissionItem]:
    """What MAVSDK's Mission plugin sends: waypoint (current=1 first), DO_CHANGE_SPEED after each."""
    plan: list[MissionItem] = []
    for i in range(n):
        plan.append(_wp(len(plan), 10.0 * (i + 1), current=1 if not plan else 0, hold_s=0.5, accept_m=3.0))
        plan.append(MissionItem(seq=len(plan), frame=mi.FRAME_MISSION, command=mi.CMD_DO_CHANGE_SPEED,
                                param1=1.0, param2=3.0, param3=-1.0, z=NAN))
    return plan


def qgc_plan(n: int, home: tuple[float, float] = HOME) -> list[MissionItem]:
    """QGC for ArduPilot: MissionSettingsItem (NAV_WAYPOINT, MAV_FRAME_GLOBAL, not current) at the
    planned home, then waypoints relative to home (MAV_FRAME_GLOBAL_RELATIVE_ALT)."""
    placeholder = MissionItem(seq=0, frame=mi.FRAME_GLOBAL, command=mi.CMD_NAV_WAYPOINT, x=_e7(home[0]),
                              y=_e7(home[1]), z=12.0)
    return [placeholder, *(_wp(i, 10.0 * i, mi.FRAME_GLOBAL_RELATIVE_ALT) for i in range(1, n + 1))]


def mavproxy_plan(n: int) -> list[MissionItem]:
    """A MAVProxy/Mission Planner ``.waypoints`` file: line 0 is home, current=1, frame 0."""
    plan = qgc_plan(n)
    return [MissionItem(**{**plan[0].to_dict(), "current": 1}), *plan[1:]]


def absolute_plan(first_north_m: float) -> list[MissionItem]:
    """A script that writes every waypoint in MAV_FRAME_GLOBAL and no placeholder."""
    return [_wp(0, first_north_m, mi.FRAME_GLOBAL), _wp(1, first_north_m + 20.0, mi.FRAME_GLOBAL)]


@pytest.mark.parametrize(("plan", "home", "expected"), [
    (mavsdk_plan(3), HOME, Convention.PLAIN),
    (mavsdk_plan(3), None, Convention.PLAIN),
    (qgc_plan(3), HOME, Convention.HOME_PLACEHOLDER),
    (qgc_plan(3, (HOME[0] + 0.01, HOME[1])), HOME, Convention.HOME_PLACEHOLDER),  # planned 1 km away
    (qgc_plan(3), None, Convention.HOME_PLACEHOLDER),
    (mavproxy_plan(3), HOME, Convention.HOME_PLACEHOLDER),
    (qgc_plan(0), None, Convention.HOME_PLACEHOLDER),  # empty ArduPilot mission before home is known
    (qgc_plan(0), HOME, Convention.HOME_PLACEHOLDER),
    ([MissionItem(seq=0, frame=0, command=16), _wp(1, 10.0, mi.FRAME_GLOBAL)], HOME,
     Convention.HOME_PLACEHOLDER),  # 0,0 cannot be a waypoint
    (absolute_plan(HOME_MATCH_M - 5.0), HOME, Convention.HOME_PLACEHOLDER),
    (absolute_plan(HOME_MATCH_M + 30.0), HOME, None),
    (absolute_plan(10.0), None, None),
    (absolute_plan(80.0)[:1], HOME, None),
    ([MissionItem(seq=0, frame=mi.FRAME_MISSION, command=mi.CMD_DO_CHANGE_SPEED, param2=2.0),
      *qgc_plan(2)[1:]], HOME, Convention.PLAIN),
])
def test_classify(plan: list[MissionItem], home: tuple[float, float] | None,
                  expected: Convention | None) -> None:
    verdict = classify(plan, home)
    assert verdict.convention is expected, verdict.reason
    if expected is None:
        assert "ambiguous" in verdict.reason and "home placeholder" in verdict.reason


def _fields(item: MissionItem | object) -> tuple[object, ...]:
    """Every transferred field of an item or a MISSION_ITEM_INT, NaN compared as NaN."""
    names = ("seq", "frame", "command", "autocontinue", "param1", "param2", "param3", "param4", "x", "y", "z")
    return tuple("nan" if isinstance(v, float) and math.isnan(v) else v
                 for v in (getattr(item, n) for n in names))


async def test_each_client_downloads_what_it_uploaded_and_progress_counts_real_items(
        state_dir: Path) -> None:
    port = free_port()
    async with AsyncGcs(port) as gcs, running_vehicle(state_dir, [port]) as services:
        ctx = services.ctx
        await gcs.connect()
        publish_nav(ctx)  # sets home
        vehicle = services.vehicle
        texts: list[str] = []
        ctx.bus.topic(STATUS_TEXT_TOPIC).add_listener(lambda s: texts.append(s.text))

        plan = mavsdk_plan(4)
        assert (await upload(gcs, plan)).type == mav.MAV_MISSION_ACCEPTED
        assert texts[-1] == "Mission received: 8 items (item 0 = 1st item)"
        got = await download(gcs)
        assert [_fields(m) for m in got] == [_fields(p) for p in plan]
        assert vehicle.first_mission_seq == 0 and vehicle.mission_total == 8
        cur = await gcs.wait("MISSION_CURRENT", timeout_s=5)
        assert (cur.seq, cur.total) == (0, 8)

        plan = qgc_plan(3, home=(HOME[0] + 2e-5, HOME[1]))  # planned home 2 m off the vehicle's
        assert (await upload(gcs, plan)).type == mav.MAV_MISSION_ACCEPTED
        assert texts[-1] == "Mission received: 4 items (item 0 = home)"
        got = await download(gcs)
        assert (got[0].frame, got[0].command, got[0].x, got[0].y) == (mi.FRAME_GLOBAL, 16, _e7(HOME[0]),
                                                                      _e7(HOME[1]))  # the vehicle's home
        assert [_fields(m) for m in got[1:]] == [_fields(p) for p in plan[1:]]
        cur = await gcs.wait("MISSION_CURRENT", lambda m: m.total == 3, 5)
        assert cur.seq == 1  # the first real waypoint

        kept = [_fields(m) for m in got]
        refused = asyncio.ensure_future(gcs.wait("STATUSTEXT", lambda m: "refused" in m.text, 10))
        ack = await upload(gcs, absolute_plan(300.0))
        assert ack.type == mav.MAV_MISSION_INVALID
        assert "item 0 ambiguous" in (await refused).text  # on the wire, first 50-character chunk
        assert "300 m from home" in texts[-1] and len(texts[-1]) <= 200  # the whole reason, 4 chunks
        assert [_fields(m) for m in await download(gcs)] == kept  # the old plan is still there

        assert (await upload(gcs, [])).type == mav.MAV_MISSION_ACCEPTED
        got = await download(gcs)  # ArduPilot's empty mission: home alone (MAVProxy waits for item 0)
        assert [(m.seq, m.frame, m.x, m.y) for m in got] == [(0, mi.FRAME_GLOBAL, _e7(HOME[0]), _e7(HOME[1]))]
        assert vehicle.mission_total == 0


def test_the_convention_survives_a_restart_and_old_files_are_classified(tmp_path: Path) -> None:
    store = MissionStore(tmp_path)
    store.replace(MissionType.MISSION, absolute_plan(10.0), home_item=True)
    assert MissionStore(tmp_path).has_home_item()
    store.replace(MissionType.MISSION, absolute_plan(10.0), home_item=False)
    assert not MissionStore(tmp_path).has_home_item()
    path = tmp_path / "mission.json"
    for plan, expected in ((qgc_plan(2), True), (mavsdk_plan(2), False)):
        data = {"mission_type": 0, "items": [item.to_dict() for item in plan]}  # saved before the flag
        path.write_text(json.dumps(data, allow_nan=True), encoding="utf-8")
        assert MissionStore(tmp_path).has_home_item() is expected
