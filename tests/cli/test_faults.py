"""Faults outside kinolab get their own message, before the work where they can be found
first: a full disk, an output path that is a file, a directory where a cache file should
be. Nothing stored before a fault is lost."""

import os
import shutil
import sqlite3
import subprocess

import pytest

from conftest import SOURCE_DIR
from test_run_command import LAZY, experiment

WORLD = str(SOURCE_DIR / "tests" / "support" / "small_forest.yaml")


@pytest.fixture
def small_disk(tmp_path):
    """A 2 MB tmpfs (needs root; skipped, and reported as skipped, otherwise)."""
    mount = tmp_path / "disk"
    mount.mkdir()
    if os.geteuid() != 0 or subprocess.run(["mount", "-t", "tmpfs", "-o", "size=2m", "tmpfs",
                                            str(mount)]).returncode != 0:
        pytest.skip("mounting a small tmpfs needs root")
    yield mount
    subprocess.run(["umount", "-l", str(mount)], check=False)


def test_a_full_disk_is_reported_as_such_and_stored_runs_survive(kinolab, tmp_path, small_disk):
    path = experiment(tmp_path, LAZY, queries="random: {count: 40, min_distance: 3, max_distance: 8}",
                      extra="store: {trajectories: true, trees: true}\n", plugins=False)
    result = kinolab("run", path, "--out", small_disk / "out")
    assert result.returncode == 1, result.stdout + result.stderr
    assert "disk is full" in result.stderr, result.stderr
    assert "rollback" not in result.stderr
    # What was committed before the disk filled is intact and resumable elsewhere.
    copy = tmp_path / "copy"
    shutil.copytree(small_disk / "out", copy)
    with sqlite3.connect(copy / "results.sqlite") as db:
        assert db.execute("PRAGMA integrity_check").fetchone() == ("ok",)
        stored = db.execute("SELECT COUNT(*) FROM runs").fetchone()[0]
    assert 0 < stored < 40
    resumed = kinolab("run", path, "--out", copy, "--resume")
    assert resumed.returncode == 0, resumed.stderr
    assert f"{stored} were already done" in resumed.stdout


def test_an_output_path_that_is_a_file_is_refused_before_any_work(kinolab, tmp_path):
    path = experiment(tmp_path, LAZY, plugins=False)
    (tmp_path / "taken").write_text("not a directory")
    result = kinolab("run", path, "--out", tmp_path / "taken")
    assert result.returncode == 1
    assert "taken: cannot create the directory" in result.stderr, result.stderr
    assert "run: world" not in result.stderr  # refused before building anything


def test_a_directory_where_the_cache_file_should_be_costs_a_rebuild(kinolab, tmp_path):
    first = kinolab("world", WORLD)
    assert first.returncode == 0, first.stderr
    cache_file = first.stdout.split("(cache: ")[1].split(")")[0]
    os.remove(cache_file)
    os.mkdir(cache_file)
    again = kinolab("world", WORLD)
    assert again.returncode == 0, again.stderr
    assert "not a regular file" in again.stdout + again.stderr


def test_a_world_larger_than_the_process_may_use_is_refused_before_it_is_built(tmp_path):
    """The up-front size check reads the process's limit (ulimit -v here; a Slurm job's or a
    container's control group likewise), not the machine's memory."""
    import resource
    from conftest import BINARY
    spec = tmp_path / "big.yaml"
    spec.write_text("name: big\nseed: 1\nresolution: 0.05\n"
                    "bounds: {min: [0, 0, 0], max: [100, 100, 5]}\ngenerators: [{type: empty}]\n")
    limit = 3 * 1024 ** 3  # 3 GiB of address space; the world needs about 6 to build

    def limited():
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))

    result = subprocess.run([BINARY, "world", str(spec), "--out", str(tmp_path / "out")],
                            capture_output=True, text=True, preexec_fn=limited, timeout=120)
    assert result.returncode == 1, result.stdout + result.stderr
    assert "this process may use 3 GiB" in result.stderr, result.stderr
    assert "resolution" in result.stderr and "big.yaml:3" in result.stderr
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())
