"""``usv sim maneuver`` as a user runs it."""

from __future__ import annotations

import subprocess
from pathlib import Path

from ..conftest import usv_command


def test_usv_sim_maneuver_writes_the_log_and_refuses_bad_flags(
    tmp_path: Path, usv_env: dict[str, str]
) -> None:
    out = tmp_path / "log.csv"
    ok = subprocess.run([*usv_command(), "sim", "maneuver", "zigzag", "--out", str(out), "--duration", "5",
                         "--amplitude", "0.35", "--current", "0.3,45", "--seed", "4"],
                        capture_output=True, text=True, env=usv_env, timeout=120)
    assert ok.returncode == 0, ok.stderr
    assert out.read_text().startswith("t,u,v,r,throttle,delta,x,y,psi,")
    bad = subprocess.run([*usv_command(), "sim", "maneuver", "sine", "--out", str(out), "--waves", "x"],
                         capture_output=True, text=True, env=usv_env, timeout=120)
    assert bad.returncode == 2 and "--waves" in bad.stderr and "Traceback" not in bad.stderr
