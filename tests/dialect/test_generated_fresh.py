"""The committed generated module is what mavgen makes from usv.xml today (never stale)."""

from __future__ import annotations

import math
import subprocess
import sys

from mavlink_dialect import generate, load, mavsdk_xml, usv, xml_text


def test_generated_module_is_not_stale() -> None:
    fresh = generate.generate_source()
    committed = generate.GENERATED_PATH.read_text(encoding="utf-8")
    assert fresh == committed, "run: python -m mavlink_dialect.generate"


def test_generation_is_reproducible() -> None:
    assert generate.generate_source() == generate.generate_source()


def test_check_mode_reports_stale_file(tmp_path) -> None:
    stale = tmp_path / "usv.py"
    stale.write_text("# old\n")
    proc = subprocess.run(
        [sys.executable, "-m", "mavlink_dialect.generate", "--check", "--output", str(stale)],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 1 and "stale" in proc.stderr
    ok = subprocess.run(
        [sys.executable, "-m", "mavlink_dialect.generate", "--check"], capture_output=True, text=True
    )
    assert ok.returncode == 0, ok.stderr


def test_messages_round_trip_through_the_generated_module() -> None:
    assert load() is usv
    tx = usv.MAVLink(None, srcSystem=1, srcComponent=1)
    rx = usv.MAVLink(None)
    msgs = [
        usv.MAVLink_usv_launcher_status_message(
            1000,
            29.5,
            20.0,
            4.5,
            1_700_000_000_000_000,
            300_000_000,
            1_200_000_000,
            9000,
            usv.USV_LAUNCHER_STATE_ARMED,
            0x1F,
            1,
        ),
        usv.MAVLink_usv_sampler_status_message(
            2000, [250.0, 0, 0, 0], 1, 2, 3, 1.25, [usv.USV_BOTTLE_STATE_FULL, 1, 0, 0], 1, 2, 1
        ),
        usv.MAVLink_usv_model_status_message(
            3000, 0.1, -0.02, 0.003, 0.01, 0.01, 0.001, 2.4, 7.8, 42, usv.USV_MODEL_HEALTH_OK
        ),
        usv.MAVLink_usv_current_estimate_message(
            4000, 0.0, 0.5, 0.5, 90.0, 0.01, 0.98, usv.USV_CURRENT_ESTIMATOR_UKF
        ),
    ]
    for msg in msgs:
        buf = msg.pack(tx)
        assert buf[0] == usv.PROTOCOL_MARKER_V2
        decoded = rx.parse_buffer(buf)
        assert decoded is not None and len(decoded) == 1
        got = decoded[0].to_dict()
        for key, value in msg.to_dict().items():
            if isinstance(value, float):
                assert math.isclose(got[key], value, rel_tol=1e-6), key
            else:
                assert got[key] == value, key


def test_xml_texts() -> None:
    assert "<include>common.xml</include>" in xml_text()
    assert "USV_LAUNCHER_STATUS" in mavsdk_xml()
