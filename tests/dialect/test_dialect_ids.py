"""The dialect's ids are free in common.xml and ardupilotmega.xml, and its commands sit in
MAVLink's reserved user range (checked against the XML shipped with pymavlink)."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

import mavlink_dialect
from mavlink_dialect import UsvCmd, usv
from mavlink_dialect.generate import pymavlink_xml_dir

REPO_ROOT = Path(__file__).resolve().parents[2]


def _with_includes(name: str, seen: set[str] | None = None) -> list[ET.Element]:
    seen = set() if seen is None else seen
    if name in seen:
        return []
    seen.add(name)
    root = ET.parse(pymavlink_xml_dir() / name).getroot()
    roots = [root]
    for inc in root.findall("include"):
        roots += _with_includes((inc.text or "").strip(), seen)
    return roots


def _message_ids(roots: list[ET.Element]) -> dict[int, str]:
    return {int(m.get("id", "-1")): m.get("name", "") for r in roots for m in r.iter("message")}


def _mav_cmds(roots: list[ET.Element]) -> dict[str, int]:
    out: dict[str, int] = {}
    for r in roots:
        for enum in r.iter("enum"):
            if enum.get("name") == "MAV_CMD":
                for e in enum.findall("entry"):
                    out[e.get("name", "")] = int(e.get("value", "-1"))
    return out


def _ours() -> ET.Element:
    return ET.parse(mavlink_dialect.XML_PATH).getroot()


@pytest.mark.parametrize("other", ["common.xml", "ardupilotmega.xml"])
def test_message_ids_and_names_do_not_collide(other: str) -> None:
    theirs = _message_ids(_with_includes(other))
    mine = _message_ids([_ours()])
    assert len(mine) == 4
    for msg_id, name in mine.items():
        assert msg_id not in theirs, f"{name} id {msg_id} collides with {theirs.get(msg_id)} in {other}"
        assert name not in theirs.values()


def test_message_ids_free_in_every_shipped_dialect() -> None:
    mine = _message_ids([_ours()])
    for xml in sorted(pymavlink_xml_dir().glob("*.xml")):
        theirs = _message_ids([ET.parse(xml).getroot()])
        assert not set(mine) & set(theirs), f"collision with {xml.name}"


def test_commands_use_the_reserved_user_range() -> None:
    common = _mav_cmds(_with_includes("common.xml"))
    waypoint_user = {common[f"MAV_CMD_WAYPOINT_USER_{i}"] for i in range(1, 6)}
    user = {common[f"MAV_CMD_USER_{i}"] for i in range(1, 6)}
    assert waypoint_user == set(range(31000, 31005)) and user == set(range(31010, 31015))
    apm = _mav_cmds(_with_includes("ardupilotmega.xml"))
    used_by_apm_outside_user = {v for n, v in apm.items() if "USER" not in n}
    for cmd in UsvCmd:
        name = cmd.name
        assert getattr(usv, f"USV_CMD_{name}") == cmd.value  # the XML and the Python enum agree
        if name.startswith("NAV_"):
            assert cmd.value in waypoint_user, f"mission item {name} must be a WAYPOINT_USER id"
        else:
            assert cmd.value in user, f"immediate command {name} must be a USER id"
        assert cmd.value not in used_by_apm_outside_user


def test_xml_enum_lists_exactly_the_python_commands() -> None:
    entries = {
        e.get("name"): int(e.get("value", "-1"))
        for enum in _ours().iter("enum")
        if enum.get("name") == "USV_CMD"
        for e in enum.findall("entry")
    }
    assert entries == {f"USV_CMD_{c.name}": c.value for c in UsvCmd}


def test_qgc_actions_file_is_valid_and_uses_dialect_commands() -> None:
    data = json.loads((REPO_ROOT / "qgc" / "usv_actions.json").read_text())
    assert data["fileType"] == "MavlinkActions" and data["version"] == 1
    labels = {a["label"] for a in data["actions"]}
    assert {"Arm launcher", "FIRE launcher", "Sample next bottle", "Stop pump"} <= labels
    allowed = {"label", "description", "mavCmd", "compId"} | {f"param{i}" for i in range(1, 8)}
    for action in data["actions"]:
        assert set(action) <= allowed, action
        assert action["description"] and action["label"]
        assert action["mavCmd"] in {c.value for c in UsvCmd}
        assert action.get("compId", 1) == 1
