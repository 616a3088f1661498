"""The qLPV model the control benchmark flies: the companion's shipped default, and how it is made.

Bench == product.  The control rig (:mod:`benchmarks.control_rig`) and the closed-loop tests use
the very ``companion/models/default_params.toml`` the companion loads when no model of its own
has been identified, so every figure of ``usv bench control`` is a figure of the shipped boat.

That file is not written by hand.  It is the ``params.toml`` of ``usv identify`` (Eq. 3-4 fitted
by least squares, then instrumental variables) on three open-loop manoeuvre logs from the
simulated boat in calm water, each recorded with ``usv sim maneuver`` through the simulated
GPS-INS (noisy, as on the water), :data:`DEFAULT_MODEL_PROTOCOL`:

* random nozzle and throttle around 50 % throttle, 300 s: surge, sway and yaw from 2 to 5 m/s;
* random nozzle and throttle around 75 % throttle, 300 s: the 5-6 m/s the missions are flown at,
  where the chapter's 30 % sine never goes;
* the chapter's sine (30 % throttle, +-pi/3, 10 s period), 120 s.

The throttle steps of the random runs are what identify the thrust map; a constant-throttle run
cannot (measured: the 120 s sine alone gave a model whose AUTO square on the full SITL stack
missed the mid-leg target, 0.68-1.49 m; with these three logs the worst leg middle is 0.22-0.45 m
on seeds 1-6 and the boat stays within 0.8-1.6 m of the square, corners included).

``python -m benchmarks.control_ident DIR [--install]`` runs these commands and writes
``DIR/report/params.toml`` (``--install``: and makes it the shipped default);
``tests/control/test_default_model.py`` checks that the shipped file is what they produce.
"""

from __future__ import annotations

import functools
import os
import shlex
import subprocess
import sys
from pathlib import Path

from companion.models.params_file import DEFAULT_PARAMS_PATH, load_model_params
from companion.models.qlpv import QLPVModel

DEFAULT_MODEL_PROTOCOL: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("random50.csv", ("random", "--throttle", "0.5", "--duration", "300", "--seed", "11")),
    ("random75.csv", ("random", "--throttle", "0.75", "--duration", "300", "--seed", "12")),
    ("sine30.csv", ("sine", "--throttle", "0.3", "--duration", "120", "--seed", "1")),
)
"""Training logs of the shipped default model: file name and ``usv sim maneuver`` arguments."""
REPO_ROOT = Path(__file__).resolve().parent.parent
VALIDATION_LOG: tuple[str, tuple[str, ...]] = (
    "zigzag_val.csv", ("zigzag", "--throttle", "0.5", "--duration", "60", "--seed", "3",
                       "--current", "0.1,90", "--waves", "0.05"))
"""A log none of the training runs saw (other seed, current and waves), for the report."""


def default_model_commands() -> list[list[str]]:
    """The ``usv`` command lines (without the program name; run in one directory) that write
    ``report/params.toml`` there."""
    logs = [*DEFAULT_MODEL_PROTOCOL, VALIDATION_LOG]
    cmds = [["sim", "maneuver", *args, "--out", name] for name, args in logs]
    cmds.append(["identify", *(name for name, _ in DEFAULT_MODEL_PROTOCOL),
                 "--validate", VALIDATION_LOG[0], "--report", "report"])
    return cmds


def identify_default_model(work_dir: Path, echo: bool = False) -> Path:
    """Run :func:`default_model_commands` (each as its own ``usv`` process) and return the
    ``params.toml`` written; raises :class:`subprocess.CalledProcessError` if one fails."""
    work_dir.mkdir(parents=True, exist_ok=True)
    path = os.pathsep.join(filter(None, (str(REPO_ROOT), os.environ.get("PYTHONPATH"))))
    env = {**os.environ, "PYTHONPATH": path}
    for cmd in default_model_commands():
        if echo:
            print("usv " + shlex.join(cmd), flush=True)
        subprocess.run([sys.executable, "-m", "companion.cli", *cmd], check=True, cwd=work_dir, env=env,
                       stdout=None if echo else subprocess.DEVNULL)
    return work_dir / "report" / "params.toml"


@functools.cache
def shipped_model() -> QLPVModel:
    """The companion's shipped default qLPV model (cached)."""
    return load_model_params()


HEADER = ("# The companion's default qLPV model (Eq. 3-4).  Written by\n"
          "# `python -m benchmarks.control_ident DIR --install` from simulated manoeuvre logs\n"
          "# (see that module); do not edit by hand.\n")


if __name__ == "__main__":  # pragma: no cover
    if len(sys.argv) not in (2, 3) or sys.argv[2:] not in ([], ["--install"]):
        sys.exit("usage: python -m benchmarks.control_ident DIR [--install]\n"
                 "  writes DIR/report/params.toml; --install also copies it to " + str(DEFAULT_PARAMS_PATH))
    made = identify_default_model(Path(sys.argv[1]), echo=True)
    print(made)
    if sys.argv[2:]:
        DEFAULT_PARAMS_PATH.write_text(HEADER + made.read_text(encoding="utf-8"), encoding="utf-8")
        print(f"installed as {DEFAULT_PARAMS_PATH}")
