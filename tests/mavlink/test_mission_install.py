"""MissionService.install: an in-process client (``usv campaign``) installs a plan through the same
checks as the end of a MAVLink upload: refused with the upload's reason and STATUSTEXT, or stored."""

from __future__ import annotations

from pathlib import Path

from companion.clock import SimClock
from companion.config import default_config
from companion.messages import STATUS_TEXT_TOPIC, StatusText
from companion.mission import items as mi
from companion.mission import validate as v
from companion.mission.items import MissionItem, MissionType
from companion.runtime import build_companion, build_context
from mavlink_dialect import UsvCmd


def test_install_checks_like_an_upload_and_stores_the_plan(tmp_path: Path) -> None:
    config = default_config().with_overrides({"vehicle.state_dir": str(tmp_path), "links.udp_targets": [],
                                              "links.tcp_listen": "", "links.tlog": False})
    services = build_companion(build_context(config, SimClock(start_unix_time_s=1.7e9)))
    texts: list[StatusText] = []
    services.ctx.bus.topic(STATUS_TEXT_TOPIC).add_listener(texts.append)
    missions = services.mavlink.missions

    speed = MissionItem(seq=0, frame=mi.FRAME_MISSION, command=mi.CMD_DO_CHANGE_SPEED, param2=3.0)
    bad = [speed, MissionItem(seq=1, frame=mi.FRAME_GLOBAL_INT, command=mi.CMD_NAV_WAYPOINT,
                              x=round(91.0 * 1e7), y=round(123.43 * 1e7))]
    problem = missions.install(MissionType.MISSION, bad)
    assert problem is not None and problem.code == v.INVALID_PARAM5_X and "latitude" in problem.reason
    assert texts[-1].text.startswith("Mission upload refused:") and "latitude" in texts[-1].text
    assert services.vehicle.missions.items(MissionType.MISSION) == []

    sample = MissionItem.at(7, UsvCmd.NAV_SAMPLE_HERE, 41.7702, 123.43, param1=9.0)  # bottle 9: no such
    problem = missions.install(MissionType.MISSION, [speed, sample])
    assert problem is not None and "bottle" in problem.reason.lower()

    good = [speed, MissionItem.waypoint(5, 41.7702, 123.4301), MissionItem.waypoint(9, 41.7703, 123.43)]
    assert missions.install(MissionType.MISSION, good) is None
    stored = services.vehicle.missions.items(MissionType.MISSION)
    assert [i.seq for i in stored] == [0, 1, 2] and [i.x for i in stored] == [i.x for i in good]
    assert texts[-1].text.startswith("Mission received: 3 items")
