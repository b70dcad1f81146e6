"""Shared fixtures for the command-line tests: the kinolab binary and a throw-away cache."""

import os
import subprocess
from pathlib import Path

import pytest

SOURCE_DIR = Path(os.environ.get("KINOLAB_SOURCE_DIR", Path(__file__).resolve().parents[2]))
# A small forest world spec (10 m x 10 m x 3 m) the command tests plan in.
SMALL_FOREST = """name: small_forest
seed: 4
resolution: 0.1
bounds: {min: [0, 0, 0], max: [10, 10, 3]}
generators:
  - {type: forest, density: 0.1, trunk_radius: [0.15, 0.25], trunk_height: [2.5, 3],
     min_spacing: 1.0, ground_plane: true}
"""

BINARY = os.environ.get("KINOLAB_BIN", str(SOURCE_DIR / "build" / "framework" / "kinolab"))


@pytest.fixture
def kinolab(tmp_path):
    """Runs `kinolab ARGS...` with a private world cache; returns the CompletedProcess."""

    def run(*args, cwd=None):
        env = dict(os.environ, KINOLAB_CACHE_DIR=str(tmp_path / "cache"))
        return subprocess.run([BINARY, *map(str, args)], capture_output=True, text=True,
                              env=env, cwd=cwd, timeout=300)

    return run
