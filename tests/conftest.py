"""Shared test helpers: the installed ``usv`` command and a private state directory."""

from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

import pytest
from hypothesis import settings

settings.register_profile("repeatable", derandomize=True, deadline=None)
"""The suite's default: the same examples on every run and machine (a red CI is a regression, not
a lucky draw), and no wall-clock deadline per example (timing follows the simulated clock)."""
settings.register_profile("explore", max_examples=2000, deadline=None)
"""``HYPOTHESIS_PROFILE=explore``: new random examples, many of them, to search for counterexamples."""
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "repeatable"))

REPO_ROOT = Path(__file__).resolve().parents[1]


def usv_command() -> list[str]:
    """The ``usv`` console script installed next to this interpreter (as a user runs it)."""
    script = Path(sys.executable).with_name("usv")
    if script.exists():
        return [str(script)]
    found = shutil.which("usv")
    if found:
        return [found]
    return [sys.executable, "-m", "companion.cli"]


@pytest.fixture
def state_dir(tmp_path: Path) -> Path:
    d = tmp_path / "state"
    d.mkdir()
    return d


@pytest.fixture
def usv_env(tmp_path: Path) -> dict[str, str]:
    """Environment for subprocesses: state kept under the test's temporary directory."""
    env = dict(os.environ)
    env["XDG_STATE_HOME"] = str(tmp_path / "xdg-state")
    env["PYTHONUNBUFFERED"] = "1"
    return env
