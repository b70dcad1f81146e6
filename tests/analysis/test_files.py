"""What the report and export write: never through a link, never into a pipe (issue 55, kind
6); a regular file is created or emptied."""

import os

import pytest

from kinolab_analysis import files


def test_a_link_or_a_pipe_is_refused_and_its_target_untouched(tmp_path):
    victim = tmp_path / "victim.txt"
    victim.write_text("precious")
    (tmp_path / "index.html").symlink_to(victim)
    with pytest.raises(ValueError, match="index.html: is a symbolic link"):
        files.write_text(tmp_path / "index.html", "<html>")
    (tmp_path / "figures").symlink_to(tmp_path)
    with pytest.raises(ValueError, match="figures: is a symbolic link"):
        files.directory(tmp_path / "figures")
    os.mkfifo(tmp_path / "table.md")
    with pytest.raises(ValueError, match="table.md: is not a regular file"):
        files.write_text(tmp_path / "table.md", "| a |")  # refused at once, not waited on
    assert victim.read_text() == "precious"


def test_a_regular_file_is_created_or_emptied_and_written(tmp_path):
    target = tmp_path / "out" / "table.tex"
    files.directory(target.parent)
    files.write_text(target, "a longer first text")
    files.write_text(target, "short")
    assert target.read_text() == "short"
    files.write_bytes(target, b"\x89PNG")
    assert target.read_bytes() == b"\x89PNG"
