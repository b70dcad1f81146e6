"""The analysis package and the viewer repeat none of kinolab's schema: what they spell
themselves (the schema version they read, the edge states they draw) must be kinolab's own,
as the built command prints it (`kinolab list metrics --json`)."""

import json
import os
import re
import subprocess
from pathlib import Path

import pandas as pd
import pytest

from kinolab_analysis import data, tables

SOURCE = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def schema():
    binary = os.environ.get("KINOLAB_BIN")
    if not binary:
        pytest.fail("KINOLAB_BIN is not set: run through ctest")
    listed = subprocess.run([binary, "list", "metrics", "--json"], capture_output=True,
                            text=True, check=True)
    return json.loads(listed.stdout)


def test_the_schema_version_read_is_the_one_written(schema):
    assert data.SCHEMA_VERSION == schema["schema_version"]


def test_edge_states_are_kinolabs_in_the_report_and_the_viewer(schema):
    # The report colours each state (data.EDGE_COLOURS) and the viewer draws it in the same
    # colour (EDGE_STATES in viewer.js; test_comparisons holds the colours equal): both know
    # exactly kinolab's states, in order.
    assert list(data.EDGE_STATES) == schema["edge_states"]
    assert list(data.EDGE_COLOURS) == schema["edge_states"]
    viewer = (SOURCE / "viewer" / "viewer.js").read_text()
    shades = re.search(r"const EDGE_STATES = \{(.*?)\n  \};", viewer, re.S).group(1)
    assert re.findall(r"^\s+(\w+): \{", shades, re.M) == schema["edge_states"]


def test_summarised_metrics_are_declared_and_take_their_units_from_the_declaration(schema):
    declared = {m["name"]: m["unit"] for kind in ("result", "runner", "flight")
                for m in schema[kind]}
    for statistics in schema["statistics"].values():
        declared.update({m["name"]: m["unit"] for m in statistics})
    for column, _ in tables.SUMMARISED:
        assert column in declared, column
    frame = pd.DataFrame({"name": list(declared), "unit": list(declared.values())})
    assert ("jerk_integral", "jerk", declared["jerk_integral"]) in tables.metrics(
        frame, ("jerk_integral",))
