"""`kinolab world` end to end: exported files, an independent ESDF check, and bad input."""

import numpy as np
import pytest
import yaml
from scipy import ndimage

from conftest import SOURCE_DIR

SMALL_WORLD = """\
name: small
seed: 3
resolution: 0.2
bounds: {min: [-1, 2, 0], max: [9, 10, 3]}
generators:
  - {type: forest, density: 0.15, trunk_radius: [0.2, 0.4], trunk_height: [1.5, 2.5]}
  - {type: boxes, count: 5, on_ground: false}
"""


def write(path, text):
    path.write_text(text)
    return path


def test_help_and_version(kinolab):
    result = kinolab("--help")
    assert result.returncode == 0
    assert "world" in result.stdout
    result = kinolab("world", "--help")
    assert result.returncode == 0
    assert "--out" in result.stdout and "--cache-dir" in result.stdout
    result = kinolab("--version")
    assert result.returncode == 0
    assert result.stdout.startswith("kinolab 0.")


def test_exports_grid_esdf_metadata_and_pictures(kinolab, tmp_path):
    spec = write(tmp_path / "small.yaml", SMALL_WORLD)
    out = tmp_path / "out"
    result = kinolab("world", spec, "--out", out)
    assert result.returncode == 0, result.stderr
    assert "built" in result.stdout

    meta = yaml.safe_load((out / "world.yaml").read_text())
    assert meta["resolution"] == pytest.approx(0.2)
    assert meta["origin"] == pytest.approx([-1, 2, 0])
    assert meta["axis_order"] == "xyz"
    occupancy = np.load(out / "occupancy.npy")
    esdf = np.load(out / "esdf.npy")
    assert occupancy.dtype == np.uint8 and esdf.dtype == np.float32
    assert occupancy.shape == esdf.shape == (50, 40, 15) == tuple(meta["shape"])
    assert int(occupancy.sum()) == meta["occupied_voxels"] > 0

    # An independent exact transform (SciPy) gives the same signed field. The field measures
    # from voxel centres to the cubes of the other kind: on the grid of half voxels a cube
    # is the 3 x 3 x 3 block around its centre, so the distance from a centre to the nearest
    # cube is the Euclidean transform of the blocks' union, read at the centres.
    def to_cubes(target):
        doubled = np.zeros(tuple(2 * n + 1 for n in target.shape), dtype=bool)
        for dx in range(3):
            for dy in range(3):
                for dz in range(3):
                    doubled[dx : dx + 2 * target.shape[0] : 2,
                            dy : dy + 2 * target.shape[1] : 2,
                            dz : dz + 2 * target.shape[2] : 2] |= target
        distance = ndimage.distance_transform_edt(~doubled)
        return distance[1::2, 1::2, 1::2] * meta["resolution"] / 2

    expected = np.where(occupancy == 1, -to_cubes(occupancy == 0), to_cubes(occupancy == 1))
    assert np.abs(esdf - expected).max() < 1e-4 * meta["resolution"]

    for picture in ("top_view.png", "esdf_slice.png"):
        data = (out / picture).read_bytes()
        assert data.startswith(b"\x89PNG\r\n\x1a\n") and len(data) > 1000

    again = kinolab("world", spec)
    assert again.returncode == 0
    assert "loaded from cache" in again.stdout


def test_shipped_map_world_exports(kinolab, tmp_path):
    result = kinolab("world", SOURCE_DIR / "configs/worlds/geb079.yaml", "--out", tmp_path / "g")
    assert result.returncode == 0, result.stderr
    occupancy = np.load(tmp_path / "g" / "occupancy.npy")
    assert occupancy.sum() >= 143729  # the map's occupied leaves


@pytest.mark.parametrize(
    "text, expected",
    [
        ("resolution: 0.1\ngenerators: [{type: empty}\n", "malformed YAML"),
        (SMALL_WORLD.replace("density", "densty"),
         "bad.yaml:6:28: generators[0].densty: world 'forest': unknown parameter 'densty' (did you mean 'density'?)"),
        (SMALL_WORLD.replace("type: forest", "type: jungle"),
         "generators[0].type: unknown world generator 'jungle'"),
        (SMALL_WORLD.replace("resolution: 0.2", "resolution: 0"),
         "bad.yaml:3:13: resolution: expected a number in [0.001, 100], got 0"),
        (SMALL_WORLD.replace("count: 5", "count: many"),
         "generators[1].count: world 'boxes': parameter 'count': expected an integer in [0, 1e+06], got 'many'"),
        (SMALL_WORLD + "colour: green\n", "bad.yaml:8:1: colour: unknown key 'colour'"),
        ("resolution: 0.1\ngenerators: [{type: octomap, file: nowhere.bt}]\n",
         "nowhere.bt: no such map file"),
    ],
)
def test_bad_specs_fail_with_one_clear_message(kinolab, tmp_path, text, expected):
    spec = write(tmp_path / "bad.yaml", text)
    out = tmp_path / "out"
    result = kinolab("world", spec, "--out", out)
    assert result.returncode != 0
    assert expected in result.stderr, result.stderr
    assert result.stderr.count("\n") == 1  # one line
    assert not out.exists()  # nothing half-written


def test_missing_spec_file(kinolab, tmp_path):
    result = kinolab("world", tmp_path / "absent.yaml")
    assert result.returncode != 0
    assert "absent.yaml: no such file" in result.stderr


def test_the_world_command_says_when_a_map_was_resampled(kinolab, tmp_path):
    bt = SOURCE_DIR / "data" / "maps" / "geb079.bt"
    coarser = write(tmp_path / "coarse.yaml",
                    f"resolution: 0.1\ngenerators:\n  - {{type: octomap, file: {bt}}}\n")
    result = kinolab("world", coarser)
    assert result.returncode == 0, result.stderr
    assert "(0.08 m voxels) resampled to 0.1 m" in result.stdout
    assert "any occupied map voxel overlaps it" in result.stdout
    own = kinolab("world", SOURCE_DIR / "configs" / "worlds" / "geb079.yaml")
    assert own.returncode == 0 and "resampled" not in own.stdout
