import asyncio
import os
import signal
import subprocess
import time
from pathlib import Path

import pytest

from companion.app import Application, BaseService

from .conftest import usv_command


class Recorder(BaseService):
    def __init__(self, name: str, log: list[str]) -> None:
        self.name = name
        self.log = log

    async def start(self) -> None:
        self.log.append(f"start {self.name}")

    async def run(self) -> None:
        try:
            await asyncio.Event().wait()
        finally:
            self.log.append(f"cancel {self.name}")

    async def stop(self) -> None:
        self.log.append(f"stop {self.name}")


async def test_services_start_in_order_and_stop_in_reverse_with_no_task_left() -> None:
    log: list[str] = []
    app = Application([Recorder("link", log), Recorder("sensors", log), Recorder("control", log)])
    runner = asyncio.create_task(app.run(install_signal_handlers=False))
    await asyncio.sleep(0.01)
    app.request_stop()
    await runner
    assert log == [
        "start link", "start sensors", "start control",
        "cancel control", "cancel sensors", "cancel link",
        "stop control", "stop sensors", "stop link",
    ]
    others = [t for t in asyncio.all_tasks() if t is not asyncio.current_task()]
    assert others == []


async def test_a_crashing_service_stops_the_others_and_is_reported() -> None:
    log: list[str] = []

    class Boom(BaseService):
        name = "boom"

        async def run(self) -> None:
            await asyncio.sleep(0.01)
            raise RuntimeError("sensor exploded")

    app = Application([Recorder("link", log), Boom()])
    with pytest.raises(ExceptionGroup) as info:
        await app.run(install_signal_handlers=False)
    assert "sensor exploded" in str(info.value.exceptions[0])
    assert log == ["start link", "cancel link", "stop link"]


async def test_running_is_the_same_life_cycle_for_a_caller_that_drives_the_clock() -> None:
    """What SitlHarness uses: the same order as run(); a crashed run() is visible in its task
    and the other services go on until the caller leaves."""
    log: list[str] = []

    class Boom(BaseService):
        name = "boom"

        async def run(self) -> None:
            raise RuntimeError("sensor exploded")

    app = Application([Recorder("link", log), Boom(), Recorder("control", log)])
    async with app.running() as tasks:
        await asyncio.sleep(0.01)
        assert [t.get_name() for t in tasks] == ["link", "boom", "control"]
        assert isinstance(tasks[1].exception(), RuntimeError) and not tasks[0].done()
    assert log == ["start link", "start control",
                   "cancel control", "cancel link", "stop control", "stop link"]
    assert app.stopped == ["control", "boom", "link"]
    others = [t for t in asyncio.all_tasks() if t is not asyncio.current_task()]
    assert others == []


def _children_of(pid: int) -> list[int]:
    out = subprocess.run(["ps", "-o", "pid=", "--ppid", str(pid)], capture_output=True, text=True)
    return [int(x) for x in out.stdout.split()]


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_usv_sitl_shuts_down_cleanly_on_signal(tmp_path: Path, usv_env: dict[str, str], sig: int) -> None:
    proc = subprocess.Popen([*usv_command(), "sitl", "--state-dir", str(tmp_path / "s")],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=usv_env)
    try:
        assert proc.stdout is not None
        deadline = time.monotonic() + 60
        banner = ""
        while "press Ctrl-C" not in banner and time.monotonic() < deadline:
            line = proc.stdout.readline()
            if not line:
                break
            banner += line
        assert "14550" in banner and "udpin://0.0.0.0:14540" in banner and "5760" in banner, banner
        children = _children_of(proc.pid)
        os.kill(proc.pid, sig)
        _, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, err
    assert "Traceback" not in err and "still running" not in err, err
    for child in children:
        assert not Path(f"/proc/{child}").exists(), f"child process {child} left behind"
