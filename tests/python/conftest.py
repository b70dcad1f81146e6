"""The Python bindings' tests: `import kinolab` from the build tree (PYTHONPATH, set by
CTest) with a private world cache."""

import os
import sys
from pathlib import Path

import pytest

SOURCE_DIR = Path(os.environ.get("KINOLAB_SOURCE_DIR", Path(__file__).resolve().parents[2]))
BINARY = os.environ.get("KINOLAB_BIN", str(SOURCE_DIR / "build" / "framework" / "kinolab"))
if "KINOLAB_PYTHON_DIR" in os.environ:
    sys.path.insert(0, os.environ["KINOLAB_PYTHON_DIR"])
SMALL_FOREST = SOURCE_DIR / "tests" / "support" / "small_forest.yaml"


@pytest.fixture(autouse=True)
def private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("KINOLAB_CACHE_DIR", str(tmp_path / "cache"))


@pytest.fixture
def forest():
    import kinolab
    return kinolab.World.from_file(SMALL_FOREST)
