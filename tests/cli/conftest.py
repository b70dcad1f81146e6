"""Shared fixtures for the command-line tests: the kinolab binary and a throw-away cache."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "support"))  # results.py
from command_line import (BINARY, SMALL_FOREST, SOURCE_DIR, last_json,  # noqa: E402,F401
                          tiny_experiment)


@pytest.fixture
def kinolab(tmp_path):
    """Runs `kinolab ARGS...` with a private world cache; returns the CompletedProcess (a
    call past `timeout` seconds fails the test)."""

    def run(*args, cwd=None, timeout=300):
        env = dict(os.environ, KINOLAB_CACHE_DIR=str(tmp_path / "cache"))
        return subprocess.run([BINARY, *map(str, args)], capture_output=True, text=True,
                              env=env, cwd=cwd, timeout=timeout)

    return run


@pytest.fixture
def world(tmp_path):
    """The small forest as a spec file (kinolab plan and fly)."""
    path = tmp_path / "world.yaml"
    path.write_text(SMALL_FOREST)
    return path
