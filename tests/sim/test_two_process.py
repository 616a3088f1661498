"""Hardware-faithful seam: ``usv sim`` and ``usv companion`` as two processes, wall clock.

The simulator owns the GPS-INS and servo ports (pseudo-terminals published under stable
symlinks, or UDP); the companion is configured with ``sensors.gnss_port`` / ``servos.port``
exactly as on the boat.  We check what a user would: a ground station on the companion's
MAVLink TCP port sees the simulated boat's position, the simulator reports the servo
frames it receives, and a simulator that dies and comes back is found again by the
companion without a restart.  These run in real time (separate processes).
"""

from __future__ import annotations

import queue
import signal
import socket
import subprocess
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from pymavlink import mavutil

from benchmarks.mavlink_gcs import free_port

from ..conftest import usv_command

HOME_A = (41.7700, 123.4300)
HOME_B = (41.7800, 123.4500)


class Proc:
    """A ``usv`` subprocess whose stdout lines are collected by a thread."""

    def __init__(self, args: list[str], env: dict[str, str], log: Path) -> None:
        self.lines: queue.Queue[str] = queue.Queue()
        self.all: list[str] = []
        self.err = log.open("w")
        self.p = subprocess.Popen([*usv_command(), *args], stdout=subprocess.PIPE, stderr=self.err, text=True,
                                  env=env)
        threading.Thread(target=self._pump, daemon=True).start()

    def _pump(self) -> None:
        assert self.p.stdout is not None
        for line in self.p.stdout:
            self.lines.put(line.rstrip("\n"))

    def wait_line(self, needle: str, timeout_s: float) -> str:
        end = time.monotonic() + timeout_s
        while time.monotonic() < end:
            try:
                line = self.lines.get(timeout=max(0.01, end - time.monotonic()))
            except queue.Empty:
                break
            self.all.append(line)
            if needle in line:
                return line
        raise AssertionError(f"no line with {needle!r} within {timeout_s} s; got {self.all[-10:]}")

    def drain(self) -> None:
        """Forget lines printed so far (status lines from before the companion connected)."""
        while True:
            try:
                self.all.append(self.lines.get_nowait())
            except queue.Empty:
                return

    def stop(self) -> int:
        if self.p.poll() is None:
            self.p.send_signal(signal.SIGINT)
            try:
                self.p.wait(10)
            except subprocess.TimeoutExpired:
                self.p.kill()
                self.p.wait()
        self.err.close()
        return int(self.p.returncode)


def write_sim_config(path: Path, home: tuple[float, float], state: Path) -> Path:
    path.write_text(f'[sim]\nhome = "{home[0]:.4f},{home[1]:.4f},0"\n[vehicle]\nstate_dir = "{state}"\n')
    return path


def write_companion_config(path: Path, gnss: str, servo: str, tcp_port: int, state: Path) -> Path:
    path.write_text(f'[links]\nudp_targets = []\ntcp_listen = "127.0.0.1:{tcp_port}"\ntlog = false\n'
                    f'[sensors]\ngnss_port = "{gnss}"\n[servos]\nport = "{servo}"\n'
                    f'[vehicle]\nstate_dir = "{state}"\n')
    return path


def positions(mav: mavutil.mavfile, timeout_s: float) -> Iterator[tuple[float, float]]:
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        msg = mav.recv_match(type="GLOBAL_POSITION_INT", blocking=True, timeout=0.5)
        if msg is not None:
            yield msg.lat * 1e-7, msg.lon * 1e-7


def wait_position(mav: mavutil.mavfile, home: tuple[float, float], timeout_s: float) -> None:
    seen = None
    for lat, lon in positions(mav, timeout_s):
        seen = (lat, lon)
        if abs(lat - home[0]) < 1e-5 and abs(lon - home[1]) < 1e-5:
            return
    raise AssertionError(f"companion never reported {home}; last GLOBAL_POSITION_INT {seen}")


def servo_frames(status_line: str) -> int:
    return int(status_line.split("servo_frames=")[1].split()[0])


def sim_args(config: Path, gnss: str, servo: str) -> list[str]:
    return ["sim", "--config", str(config), "--gnss-port", gnss, "--servo-port", servo, "--status-every", "1"]


def test_companion_process_drives_the_sim_process_over_ptys_and_survives_a_sim_restart(
    tmp_path: Path, usv_env: dict[str, str]
) -> None:
    gnss, servo = tmp_path / "gpsins", tmp_path / "servo"
    tcp = free_port(socket.SOCK_STREAM)
    sim_cfg_a = write_sim_config(tmp_path / "sim_a.toml", HOME_A, tmp_path / "sim-state")
    sim_cfg_b = write_sim_config(tmp_path / "sim_b.toml", HOME_B, tmp_path / "sim-state")
    comp_cfg = write_companion_config(tmp_path / "companion.toml", str(gnss), str(servo), tcp,
                                      tmp_path / "cs")
    sim = Proc(sim_args(sim_cfg_a, f"pty:{gnss}", f"pty:{servo}"), usv_env, tmp_path / "sim.err")
    companion = None
    sim2 = None
    try:
        sim.wait_line("servo input", 15.0)
        assert gnss.resolve().as_posix().startswith("/dev/pts/")
        companion = Proc(["companion", "--config", str(comp_cfg)], usv_env, tmp_path / "companion.err")
        companion.wait_line("ready", 15.0)
        mav = mavutil.mavlink_connection(f"tcp:127.0.0.1:{tcp}", source_system=255)
        try:
            wait_position(mav, HOME_A, 8.0)
            sim.drain()
            frames = servo_frames(sim.wait_line("servo_frames=", 3.0))
            later = servo_frames(sim.wait_line("servo_frames=", 3.0))
            assert later - frames >= 50, "the simulator should receive ~100 servo frames per second"

            sim.p.kill()  # the GPS-INS and servo ports vanish under the running companion
            sim.p.wait()
            time.sleep(1.5)
            assert companion.p.poll() is None, "the companion must survive a vanished serial device"
            sim2 = Proc(sim_args(sim_cfg_b, f"pty:{gnss}", f"pty:{servo}"), usv_env, tmp_path / "sim2.err")
            wait_position(mav, HOME_B, 12.0)  # reconnected to the new ptys behind the same names
            # each port is reopened on its own 1 s retry: the servo link may come back a status
            # line after the GPS-INS one
            frames2 = [servo_frames(sim2.wait_line("servo_frames=", 5.0)) for _ in range(3)]
            assert frames2[-1] > 0, f"the companion never drove the restarted simulator: {frames2}"
            assert companion.p.poll() is None
        finally:
            mav.close()
        assert companion.stop() == 0
        companion = None
    finally:
        for proc in (companion, sim, sim2):
            if proc is not None:
                proc.stop()
    err = (tmp_path / "companion.err").read_text()
    assert "Traceback" not in err and "reconnecting" in err


def test_companion_and_sim_over_udp(tmp_path: Path, usv_env: dict[str, str]) -> None:
    gnss_port, servo_port = free_port(socket.SOCK_DGRAM), free_port(socket.SOCK_DGRAM)
    tcp = free_port(socket.SOCK_STREAM)
    sim_cfg = write_sim_config(tmp_path / "sim.toml", HOME_B, tmp_path / "sim-state")
    comp_cfg = write_companion_config(tmp_path / "companion.toml", f"udp:127.0.0.1:{gnss_port}",
                                      f"udpout:127.0.0.1:{servo_port}", tcp, tmp_path / "cs")
    companion = Proc(["companion", "--config", str(comp_cfg)], usv_env, tmp_path / "companion.err")
    sim = None
    try:
        companion.wait_line("ready", 15.0)
        sim = Proc(sim_args(sim_cfg, f"udpout:127.0.0.1:{gnss_port}", f"udp:127.0.0.1:{servo_port}"), usv_env,
                   tmp_path / "sim.err")
        printed = sim.wait_line("sensors.gnss_port", 15.0)
        assert f'"udp:127.0.0.1:{gnss_port}"' in printed and f'"udpout:127.0.0.1:{servo_port}"' in printed
        mav = mavutil.mavlink_connection(f"tcp:127.0.0.1:{tcp}", source_system=255)
        try:
            wait_position(mav, HOME_B, 8.0)
        finally:
            mav.close()
        sim.drain()
        frames = servo_frames(sim.wait_line("servo_frames=", 3.0))
        assert servo_frames(sim.wait_line("servo_frames=", 3.0)) - frames >= 50
    finally:
        for proc in (sim, companion):
            if proc is not None:
                assert proc.stop() == 0


@pytest.mark.parametrize("spec", ["pty:", "udp:nohost", "udpout:127.0.0.1:99999"])
def test_bad_port_specs_are_refused_with_the_flag_name(spec: str, usv_env: dict[str, str]) -> None:
    bad = subprocess.run([*usv_command(), "sim", "--gnss-port", spec], capture_output=True, text=True,
                         env=usv_env, timeout=60)
    assert bad.returncode == 2 and "--gnss-port" in bad.stderr and "Traceback" not in bad.stderr
