"""Shared fixtures of the isowrench pytest suite (run with PYTHONPATH=<build>/python)."""

import os
import pathlib
import shutil
import subprocess
import json

import pytest

import isowrench

REPO = pathlib.Path(__file__).resolve().parents[2]
URDF = REPO / "urdf"


def cli_path():
    """The built CLI: $ISOWRENCH_CLI, else <build>/isowrench next to <build>/python/isowrench."""
    env = os.environ.get("ISOWRENCH_CLI")
    if env:
        return env
    candidate = pathlib.Path(isowrench.__file__).resolve().parents[2] / "isowrench"
    if candidate.exists():
        return str(candidate)
    return shutil.which("isowrench")


@pytest.fixture(scope="session")
def cli():
    path = cli_path()
    if not path:
        pytest.skip("the isowrench CLI is not built next to the module (set ISOWRENCH_CLI)")

    def run(*args):
        out = subprocess.run([path, *map(str, args)], capture_output=True, text=True)
        # Exit code 4: no equilibrium (self-motion); the JSON is still printed.
        assert out.returncode in (0, 4), (args, out.returncode, out.stderr)
        return json.loads(out.stdout)

    return run


@pytest.fixture(scope="session")
def rat():
    return isowrench.load(str(URDF / "rat_hindlimb_5dof.urdf"))
