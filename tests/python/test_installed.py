"""kinolab installed, used outside the clone: the world specs, experiments and maps the docs use
are installed under <prefix>/share/kinolab, and the installed Python package finds them by the
paths the docs give (configs/worlds/..., experiments/...)."""

import os
import subprocess
import sys
from pathlib import Path

from conftest import SOURCE_DIR

BUILD_DIR = Path(os.environ.get("KINOLAB_PYTHON_DIR", SOURCE_DIR / "build" / "python")).parent

SCRIPT = """
import kinolab
print(kinolab.__file__)
print(kinolab.World.from_file("configs/worlds/geb079.yaml", cache=False).name)  # map: ../../data
print(kinolab.data_path("experiments/quick.yaml"))
try:
    kinolab.World.from_file("configs/worlds/nowhere.yaml")
except kinolab.FileError as error:
    print(error)
"""


def test_the_installed_package_finds_the_docs_files_outside_the_clone(tmp_path):
    prefix = tmp_path / "prefix"
    subprocess.run(["cmake", "--install", str(BUILD_DIR), "--prefix", str(prefix)], check=True,
                   capture_output=True, timeout=300)
    share = prefix / "share" / "kinolab"
    for name in ("configs/worlds/dense_forest.yaml", "experiments/quick.yaml",
                 "experiments/lazy_regime/base.yaml", "data/maps/geb079.bt"):
        assert (share / name).is_file(), name
    package = next(prefix.rglob("kinolab/__init__.py")).parent
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    result = subprocess.run([sys.executable, "-c", SCRIPT], cwd=elsewhere, capture_output=True,
                            text=True, timeout=120,
                            env=dict(os.environ, PYTHONPATH=str(package.parent)))
    assert result.returncode == 0, result.stderr
    imported, world, quick, missing = result.stdout.splitlines()
    assert Path(imported).parent == package  # the installed package, not the build tree's
    assert world == "geb079"
    assert Path(quick).resolve() == (share / "experiments" / "quick.yaml").resolve()
    assert "configs/worlds/nowhere.yaml" in missing  # not found anywhere: named as given
