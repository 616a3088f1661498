"""Each mission script pointed at a URL where no vehicle answers fails within its connection
timeout with a clear message and exit status 3 (no SITL needed)."""

from __future__ import annotations

import subprocess
import sys
import time

import pytest

from tests.conftest import REPO_ROOT
from tests.mavlink.gcs import free_port

pytestmark = pytest.mark.integration

SCRIPTS = ("rescue", "water_sampling", "search")
CONNECT_TIMEOUT_S = 3.0


def test_no_vehicle_at_the_url_fails_within_the_timeout_with_a_clear_message() -> None:
    started = time.monotonic()
    procs = {name: subprocess.Popen([sys.executable, str(REPO_ROOT / "missions" / f"{name}.py"), "--url",
                                     f"udpin://127.0.0.1:{free_port()}", "--connect-timeout",
                                     str(CONNECT_TIMEOUT_S)],
                                    stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for name in SCRIPTS}
    for name, proc in procs.items():
        _, err = proc.communicate(timeout=60)
        assert proc.returncode == 3, err
        assert f"{name}: FAILED: no vehicle answered at udpin://127.0.0.1:" in err, err
        assert f"within {CONNECT_TIMEOUT_S:.0f} s" in err, err
        assert "Traceback" not in err
    assert time.monotonic() - started < CONNECT_TIMEOUT_S + 30.0  # imports and MAVSDK start-up included


BAD_ARGUMENTS = [
    (["rescue", "--standoff", "200"], "--standoff 200.0 m: must be in (0, 150]"),
    (["water_sampling", "--points", "1,2", "3,4"], "expected 4 arguments"),
    (["search", "--min-coverage", "2"], "--min-coverage is a fraction"),
    (["rescue", "--casualty", "north"], "--casualty: expected two numbers"),
]


def test_bad_arguments_are_refused_before_connecting() -> None:
    procs = [(subprocess.Popen([sys.executable, str(REPO_ROOT / "missions" / f"{args[0]}.py"), *args[1:]],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True), message)
             for args, message in BAD_ARGUMENTS]
    for proc, message in procs:
        _, err = proc.communicate(timeout=60)
        assert proc.returncode == 2 and message in err, err
