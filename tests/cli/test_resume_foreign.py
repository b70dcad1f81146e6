"""`kinolab run --resume` into a results directory whose database is not this experiment's:
refused with the reason before a byte of it changes (its hash is compared), and no -wal or
-shm file is left beside it (the runner's lock file aside)."""

import hashlib
import sqlite3
from contextlib import closing

import pytest

from conftest import tiny_experiment



@pytest.fixture
def experiments(tmp_path):
    return [tiny_experiment(tmp_path, "resume_foreign", seed, queries=2) for seed in (5, 6)]


def sql(path, *statements):
    with closing(sqlite3.connect(path)) as db:
        for statement in statements:
            db.execute(statement)
        db.commit()


def files(directory):
    """The directory's files but the runner's lock file (made by every run, also kept)."""
    return sorted(p.name for p in directory.iterdir() if p.name != ".kinolab.lock")


def digest(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_a_foreign_empty_meta_or_corrupt_database_is_refused_untouched(kinolab, experiments,
                                                                        tmp_path):
    mine, other = experiments
    # Another experiment's results, and the same with its meta emptied (runs of nobody).
    other_out = tmp_path / "other"
    assert kinolab("run", other, "--out", other_out).returncode == 0
    empty_meta = tmp_path / "empty_meta"
    empty_meta.mkdir()
    (empty_meta / "results.sqlite").write_bytes((other_out / "results.sqlite").read_bytes())
    sql(empty_meta / "results.sqlite", "DELETE FROM meta")
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    sql(foreign / "results.sqlite", "CREATE TABLE notes (text)", "INSERT INTO notes VALUES ('x')")
    corrupt = tmp_path / "corrupt"
    corrupt.mkdir()
    (corrupt / "results.sqlite").write_bytes(b"SQLite format 3\0" + bytes(range(256)) * 16)
    for directory, reason in ((other_out, "holds another experiment"),
                              (empty_meta, "runs but no experiment"),
                              (foreign, "not a kinolab results database (its tables: notes)"),
                              (corrupt, "not a readable SQLite database")):
        database = directory / "results.sqlite"
        before = digest(database)
        listing = files(directory)
        result = kinolab("run", mine, "--out", directory, "--resume")
        assert result.returncode == 1, result.stderr
        assert reason in result.stderr and str(database) in result.stderr, result.stderr
        assert digest(database) == before, directory
        assert files(directory) == listing, directory


def test_its_own_database_resumes_and_an_empty_file_starts_fresh(kinolab, experiments,
                                                                 tmp_path):
    mine, _ = experiments
    out = tmp_path / "mine"
    assert kinolab("run", mine, "--out", out).returncode == 0
    resumed = kinolab("run", mine, "--out", out, "--resume")
    assert resumed.returncode == 0 and "2 were already done" in resumed.stdout, resumed.stdout
    empty = tmp_path / "empty"
    empty.mkdir()
    (empty / "results.sqlite").write_bytes(b"")
    assert kinolab("run", mine, "--out", empty).returncode == 0


def test_its_own_database_with_a_column_dropped_is_refused_before_its_meta_is_rewritten(
        kinolab, experiments, tmp_path):
    """Before: the meta table was rewritten (last_started_at, ...), then the first insert
    failed on the missing column. Now refused naming the database, table and column, the file
    as it was; `merge` refuses it alike."""
    mine, _ = experiments
    out = tmp_path / "mine"
    assert kinolab("run", mine, "--out", out).returncode == 0
    database = out / "results.sqlite"
    sql(database, "ALTER TABLE runs DROP COLUMN cost", "DELETE FROM runs WHERE query = 1")
    with closing(sqlite3.connect(database)) as db:
        meta = db.execute("SELECT key, value FROM meta ORDER BY key").fetchall()
    before = digest(database)
    result = kinolab("run", mine, "--out", out, "--resume")
    assert result.returncode == 1, result.stderr
    assert f"{database}: table runs, column 'cost': missing" in result.stderr, result.stderr
    assert digest(database) == before
    with closing(sqlite3.connect(database)) as db:
        assert db.execute("SELECT key, value FROM meta ORDER BY key").fetchall() == meta
    merged = kinolab("merge", tmp_path / "merged.sqlite", database)
    assert merged.returncode == 1 and "table runs, column 'cost': missing" in merged.stderr, \
        merged.stderr
