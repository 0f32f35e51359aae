"""Shared helpers: the repository root and the `lucent` command to compare against.

The command is $LUCENT_BIN when set, else target/release/lucent or target/debug/lucent of the
workspace (`.ci/run` builds it before running pytest). Tests that compare against it fail,
rather than skip, when it is missing.
"""

import json
import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


def lucent_bin() -> str:
    env = os.environ.get("LUCENT_BIN")
    if env:
        return env
    for profile in ("release", "debug"):
        p = ROOT / "target" / profile / "lucent"
        if p.is_file():
            return str(p)
    raise RuntimeError("the lucent command was not found: build it (cargo build -p lucent) or set LUCENT_BIN")


def cli(*args, cwd=None) -> subprocess.CompletedProcess:
    return subprocess.run([lucent_bin(), *map(str, args)], capture_output=True, text=True, cwd=cwd, timeout=600)


def cli_json(*args, cwd=None):
    r = cli(*args, cwd=cwd)
    assert r.returncode == 0, f"lucent {' '.join(map(str, args))} failed: {r.stderr}"
    return json.loads(r.stdout)


@pytest.fixture
def root() -> pathlib.Path:
    return ROOT
