"""Run ``usv sitl`` as a subprocess for integration tests with real clients (MAVSDK, MAVProxy)."""

from __future__ import annotations

import contextlib
import subprocess
import time
from collections.abc import Iterator, Sequence
from pathlib import Path

from tests.conftest import usv_command


def write_config(path: Path, state_dir: Path, udp_ports: list[int], tcp_port: int | None = None) -> Path:
    targets = ", ".join(f'"127.0.0.1:{p}"' for p in udp_ports)
    tcp = f"127.0.0.1:{tcp_port}" if tcp_port else ""
    path.write_text(f'[vehicle]\nstate_dir = "{state_dir}"\n[links]\nudp_targets = [{targets}]\n'
                    f'tcp_listen = "{tcp}"\n', encoding="utf-8")
    return path


@contextlib.contextmanager
def sitl(config: Path, env: dict[str, str], *, speedup: float = 1.0, log: Path | None = None,
         ready_timeout_s: float = 60.0, extra_args: Sequence[str] = ()) -> Iterator[subprocess.Popen[bytes]]:
    """``usv sitl`` following the wall clock (``speedup`` x), stopped with SIGINT afterwards.

    ``extra_args``: more command-line flags (``--current``, ``--wind``, ``--waves``, ``--seed``).
    """
    args = [*usv_command(), "sitl", "-c", str(config), *extra_args]
    args += ["--realtime"] if speedup == 1.0 else ["--speedup", str(speedup)]
    out_path = log or config.with_suffix(".log")
    out = open(out_path, "wb")  # noqa: SIM115 - closed below
    proc = subprocess.Popen(args, stdout=out, stderr=subprocess.STDOUT, env=env)
    try:
        deadline = time.monotonic() + ready_timeout_s
        while b"ready" not in out_path.read_bytes():
            if proc.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError(f"usv sitl did not start:\n{out_path.read_text(errors='replace')}")
            time.sleep(0.1)
        yield proc
    finally:
        if proc.poll() is None:
            proc.send_signal(2)
            try:
                proc.wait(15)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(5)
        out.close()
