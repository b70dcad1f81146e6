"""The hostile-input suite's fixtures: the kinolab binary with a private world cache, the
small forest, a tiny experiment's results, and the check every refusal passes."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "support"))
from command_line import BINARY, SMALL_FOREST, last_json, tiny_experiment  # noqa: E402,F401

if "KINOLAB_PYTHON_DIR" in os.environ:  # the build tree's bindings (CTest sets it)
    sys.path.insert(0, os.environ["KINOLAB_PYTHON_DIR"])


def run_kinolab(cache, *args, preexec_fn=None):
    """`kinolab ARGS...` with the world cache `cache`; the CompletedProcess."""
    return subprocess.run([BINARY, *map(str, args)], capture_output=True, text=True, timeout=120,
                          env=dict(os.environ, KINOLAB_CACHE_DIR=str(cache)),
                          preexec_fn=preexec_fn)


@pytest.fixture
def kinolab(tmp_path):
    return lambda *args, **options: run_kinolab(tmp_path / "cache", *args, **options)


@pytest.fixture
def forest(tmp_path):
    path = tmp_path / "forest.yaml"
    path.write_text(SMALL_FOREST)
    return path


def refused(result, *needles):
    """A clear refusal: exit 1, one `kinolab: error:` line holding every needle, no trace."""
    assert result.returncode == 1, (result.returncode, result.stdout[-2000:], result.stderr)
    for word in ("Traceback", "unexpected error", "please report it", "terminate called"):
        assert word not in result.stderr, result.stderr
    errors = [line for line in result.stderr.splitlines() if line.startswith("kinolab: error: ")]
    assert len(errors) == 1, result.stderr
    for needle in needles:
        assert needle in errors[0], errors[0]
    return errors[0]




@pytest.fixture(scope="session")
def results(tmp_path_factory):
    """A tiny experiment's file and results directory (copy before damaging it)."""
    base = tmp_path_factory.mktemp("hostile_results")
    experiment = tiny_experiment(base, "hostile_tiny", 5, queries=2)
    out = base / "out"
    result = run_kinolab(base / "cache", "run", experiment, "--out", out)
    assert result.returncode == 0, result.stderr
    return experiment, out

