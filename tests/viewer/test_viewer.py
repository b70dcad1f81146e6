"""The 3D viewer in headless Chromium (Debian's chromium and chromedriver, through
Selenium): the page kinolab writes renders a canvas that is not blank, each layer's
checkbox toggles what is drawn, a flight's replay grows its known map, planners and tree
edge states have the report's colours, dense trees are thinned; and a report reads at
1,100 and 1,600 px."""

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from selenium import webdriver
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import WebDriverWait

SOURCE_DIR = Path(os.environ.get("KINOLAB_SOURCE_DIR", Path(__file__).resolve().parents[2]))
BINARY = os.environ.get("KINOLAB_BIN", str(SOURCE_DIR / "build" / "framework" / "kinolab"))
WORLD = SOURCE_DIR / "tests" / "support" / "small_forest.yaml"
sys.path.insert(0, str(SOURCE_DIR / "analysis"))
from kinolab_analysis import data, plots, view  # noqa: E402  (the source tree's package)


def kinolab(*args, tmp_path):
    env = dict(os.environ, KINOLAB_CACHE_DIR=str(tmp_path / "cache"))
    result = subprocess.run([BINARY, *map(str, args)], capture_output=True, text=True, env=env,
                            timeout=300)
    assert result.returncode == 0, result.stderr
    return result


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    chromium, driver = shutil.which("chromium"), shutil.which("chromedriver")
    assert chromium and driver, "Debian's chromium and chromium-driver: scripts/setup_debian.sh"
    options = webdriver.ChromeOptions()
    options.binary_location = chromium
    for argument in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage",
                     "--window-size=1000,700", "--enable-unsafe-swiftshader",
                     f"--user-data-dir={tmp_path_factory.mktemp('profile')}"):
        options.add_argument(argument)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    with webdriver.Chrome(service=Service(driver), options=options) as browser:
        yield browser


def open_view(browser, path):
    browser.get(Path(path).resolve().as_uri())
    WebDriverWait(browser, 60).until(
        lambda b: b.execute_script("return window.kinolabViewer && window.kinolabViewer.ready"))
    errors = [entry for entry in browser.get_log("browser") if entry["level"] == "SEVERE"]
    assert not errors, errors


def painted(browser):
    return browser.execute_script("return kinolabViewer.paintedPixels().painted")


def picture(browser):
    """The canvas's painted pixels and a digest of all of them."""
    state = browser.execute_script("return kinolabViewer.paintedPixels()")
    return state["painted"], state["digest"]


def click(browser, layer):
    browser.find_element(By.ID, f"layer-{layer}").click()
    return picture(browser)


def test_a_plans_view_renders_and_every_layer_toggles(browser, tmp_path):
    kinolab("plan", "--world", WORLD, "--planner", "lazy_mp_astar", "--start", "1,1,1.5",
            "--goal", "9,8,1.5", "--out", tmp_path / "plan", tmp_path=tmp_path)
    open_view(browser, tmp_path / "plan" / "view.html")
    total = browser.execute_script("return kinolabViewer.paintedPixels().total")
    everything = picture(browser)
    assert everything[0] > 0.05 * total  # the forest and the tree: not a blank canvas
    layers = browser.execute_script("return kinolabViewer.layers()")
    assert "obstacles" in layers and "q0-trajectory-lazy_mp_astar" in layers
    assert {"q0-tree-lazy_mp_astar-partial", "q0-tree-lazy_mp_astar-full"} <= set(layers)
    for layer in layers:
        hidden = click(browser, layer)
        assert hidden[0] <= everything[0] and hidden[1] != everything[1], f"hiding {layer}"
        assert click(browser, layer) == everything, f"showing {layer} again changed the view"
    # One planner alone: its tree is shown, each edge state in the 2D figures' colour, the
    # trajectory in the report's colour of the planner (the page's scene brings none: the
    # viewer computes the same).
    checked = browser.execute_script(
        "return [...document.querySelectorAll('#layers input[type=checkbox]')]"
        ".filter(i => i.id.includes('-tree-')).map(i => i.checked)")
    assert checked and all(checked)
    for state in ("partial", "full"):
        assert swatches(browser, f"q0-tree-lazy_mp_astar-{state}") == [data.EDGE_COLOURS[state]]
    assert swatches(browser, "q0-trajectory-") == [
        plots.planner_colours(["lazy_mp_astar"])["lazy_mp_astar"]]
    # Without obstacles or trees, only the trajectory over the floor remains; then the floor.
    for layer in layers:
        if layer != "q0-trajectory-lazy_mp_astar":
            click(browser, layer)
    alone = painted(browser)
    assert alone < everything[0]
    assert click(browser, "q0-trajectory-lazy_mp_astar")[0] < alone


def swatches(browser, prefix):
    """The legend swatch colours (#rrggbb) of the layers whose ids start with `prefix`."""
    values = browser.execute_script(
        "return [...document.querySelectorAll('#layers input')].filter(i => i.id.startsWith("
        "'layer-' + arguments[0])).map(i => getComputedStyle(i.nextSibling).backgroundColor)",
        prefix)
    return ["#%02x%02x%02x" % tuple(int(v) for v in re.findall(r"\d+", css)[:3])
            for css in values]


def test_a_dense_tree_is_thinned_and_the_legend_says_so(browser, tmp_path):
    """10,000 partial edges of five segments: 3,000 drawn, evenly chosen, whole."""
    template = Path(os.environ.get("KINOLAB_VIEWER") or
                    Path(BINARY).resolve().parents[1] / "share" / "kinolab" / "viewer.html")
    edges = []
    for k in range(10_000):
        x, y = k % 100 * 0.1, k // 100 * 0.1
        points = [(x, y + 0.02 * i, 1.0) for i in range(6)]
        edges += [c for a, b in zip(points, points[1:]) for c in (*a, *b)]
    scene = {"format": "kinolab-scene", "version": 1, "title": "dense",
             "world": {"name": "w", "spec_hash": "h", "resolution": 0.1, "origin": [0, 0, 0],
                       "dims": [100, 100, 30], "stride": 1, "boxes": [0, 0, 0, 1, 1, 1]},
             "queries": [{"name": "q", "start": [0, 0, 1], "goal": [9, 9, 1],
                          "trajectories": [{"planner": "lazy", "points": [0, 0, 1, 9, 9, 1]}],
                          "trees": [{"planner": "lazy", "edges": {
                              "partial": edges, "full": edges[:60], "certified": [],
                              "rejected": []}}], "flights": []}]}
    (tmp_path / "dense.html").write_text(view.page(scene, template))
    open_view(browser, tmp_path / "dense.html")
    legend = browser.execute_script("return document.body.innerText")
    assert "lazy: partial edges (3,000 of 10,000 drawn)" in legend, legend
    assert "lazy: full edges (2)" in legend, legend
    segments = browser.execute_script(
        "return ['partial', 'full'].map(s => kinolabViewer.segments('q0-tree-lazy-' + s))")
    assert segments == [3000 * 5, 2 * 5]


def test_the_query_is_framed_clear_of_the_panel(browser, tmp_path):
    """At two window sizes, the start, the goal and every trajectory point land on the canvas
    right of the layer panel."""
    kinolab("plan", "--world", WORLD, "--planner", "eager_mp_astar", "--start", "1,1,1.5",
            "--goal", "9,8,1.5", "--out", tmp_path / "plan", tmp_path=tmp_path)
    size = browser.get_window_size()
    try:
        for width, height in ((1000, 700), (1400, 800)):
            browser.set_window_size(width, height)
            open_view(browser, tmp_path / "plan" / "view.html")
            state = browser.execute_script(
                "const q = kinolabViewer.scene.queries[0];"
                "const points = [q.start, q.goal];"
                "const flat = q.trajectories[0].points;"
                "for (let i = 0; i < flat.length; i += 3) points.push(flat.slice(i, i + 3));"
                "return {panel: document.getElementById('panel').getBoundingClientRect().right,"
                " width: innerWidth, height: innerHeight,"
                " screen: points.map(p => kinolabViewer.screenOf(p))};")
            assert len(state["screen"]) > 10
            for point in state["screen"]:
                assert state["panel"] < point["x"] < state["width"], (width, point, state["panel"])
                assert 0 < point["y"] < state["height"], (width, point)
    finally:
        browser.set_window_size(size["width"], size["height"])


def test_a_flights_view_replays_the_known_map_growing(browser, tmp_path):
    kinolab("fly", "--world", WORLD, "--planner", "lazy_mp_astar", "--start", "1,1,1.5",
            "--goal", "9,9,1.5", "--out", tmp_path / "fly", tmp_path=tmp_path)
    open_view(browser, tmp_path / "fly" / "view.html")
    layers = browser.execute_script("return kinolabViewer.layers()")
    assert {"q0-flight-lazy_mp_astar", "q0-known-lazy_mp_astar"} <= set(layers)
    click(browser, "obstacles")  # the ground truth off: what remains is what the vehicle saw
    end = painted(browser)
    browser.execute_script("kinolabViewer.setTime(0)")
    start = painted(browser)
    assert start < end  # at t = 0 the vehicle has seen less and flown nothing
    slider = browser.find_element(By.ID, "time")
    assert float(slider.get_attribute("value")) == 0
    browser.execute_script("kinolabViewer.setTime(1e9)")
    assert painted(browser) == end
    assert click(browser, "q0-known-lazy_mp_astar")[0] < end


def test_a_real_octomap_opens_and_can_be_cut_open(browser, tmp_path):
    """geb079 (the OctoMap project's corridor scan): its obstacles render, and the "cut
    above" slider takes the ceiling off so that the path inside shows."""
    kinolab("plan", "--world", SOURCE_DIR / "configs" / "worlds" / "geb079.yaml", "--planner",
            "lazy_mp_astar", "--start", "0,0,0.7", "--goal", "20,0,0.7", "--out",
            tmp_path / "geb079", tmp_path=tmp_path)
    open_view(browser, tmp_path / "geb079" / "view.html")
    whole = picture(browser)
    total = browser.execute_script("return kinolabViewer.paintedPixels().total")
    assert whole[0] > 0.1 * total
    top = float(browser.find_element(By.ID, "cut").get_attribute("max"))
    browser.execute_script("kinolabViewer.setCut(1.6)")
    assert "cut above 1.60 m" in browser.find_element(By.ID, "layers").text
    opened = picture(browser)
    assert opened[1] != whole[1]
    browser.execute_script(f"kinolabViewer.setCut({top})")
    assert picture(browser) == whole


def test_a_python_scene_with_two_results_of_one_name_keeps_both_layers(browser, tmp_path,
                                                                       monkeypatch):
    monkeypatch.syspath_prepend(os.environ.get("KINOLAB_PYTHON_DIR",
                                               str(SOURCE_DIR / "build" / "python")))
    monkeypatch.setenv("KINOLAB_CACHE_DIR", str(tmp_path / "cache"))
    # The bindings are built by default (CI); a build with -DKINOLAB_BUILD_PYTHON=OFF has none.
    kinolab = pytest.importorskip("kinolab")
    world = kinolab.World.from_file(WORLD)
    scene = kinolab.Scene("two of a name", world)
    query = scene.add_query("q", (1, 1, 1.5), (9, 8, 1.5))
    for goal in ((9, 8, 1.5), (8, 2, 1.5)):
        scene.add_result(query, "same", kinolab.Planner("eager_mp_astar", world).plan((1, 1, 1.5), goal))
    open_view(browser, scene.write(tmp_path / "view.html"))
    layers = browser.execute_script("return kinolabViewer.layers()")
    assert {"q0-trajectory-same", "q0-trajectory-same-2"} <= set(layers)
    everything = picture(browser)
    for layer in ("q0-trajectory-same", "q0-trajectory-same-2"):
        assert click(browser, layer)[1] != everything[1]
        assert click(browser, layer) == everything


REPORT_EXPERIMENT = """kind: planning
name: wide
seed: 3
worlds:
  - id: forest
    spec:
SPEC
queries:
  random: {count: 6, min_distance: 3, max_distance: 8}
planners:
  - id: eager
    type: eager_mp_astar
  - id: lazy
    type: lazy_mp_astar
  - id: tgk
    type: rrtstar_ceres
reproduces: {paper: lazy_mp_astar_paper, rows: {eager: MP-A*, lazy: Lazy, tgk: TGK}}
budget: {time: 5, memory_mb: 2048}
timing: {warmup: 0, repeats: 1}
store: {trajectories: true, trees: 1}
sweep:
  grid:
    planners.lazy.params.edge_samples: [2, 20]
    worlds.forest.spec.generators.0.density: [0.05, 0.1]
"""


def test_a_report_reads_at_1100_pixels_and_uses_the_width_at_1600(browser, tmp_path):
    """The report of a three-planner sweep over a planner's and the world's parameters with
    the paper's table (its widest tables) at 1,100 and 1,600 px: no table is wider than its
    box (no column hidden behind a scroll), the page never scrolls sideways, and at 1,600 px
    the page is wider than 1,300 px."""
    config = tmp_path / "wide.yaml"
    config.write_text(REPORT_EXPERIMENT.replace("SPEC\n", "".join(
        " " * 6 + line for line in WORLD.read_text().splitlines(keepends=True))))
    kinolab("run", config, "--out", tmp_path / "out", "-j", "2", tmp_path=tmp_path)
    kinolab("report", tmp_path / "out", tmp_path=tmp_path)
    size = browser.get_window_size()
    states = {}
    try:
        for width in (1100, 1600):
            browser.set_window_size(width, 900)
            browser.get((tmp_path / "out" / "report" / "index.html").resolve().as_uri())
            WebDriverWait(browser, 60).until(
                lambda b: b.execute_script("return document.readyState") == "complete")
            states[width] = browser.execute_script(
                "const page = document.documentElement;"
                "return {page: page.scrollWidth, view: page.clientWidth,"
                " body: document.body.getBoundingClientRect().width,"
                " tables: document.querySelectorAll('table').length,"
                " hiding: [...document.querySelectorAll('table')]"
                "   .filter(t => t.scrollWidth > t.parentElement.clientWidth)"
                "   .map(t => [t.rows[0].innerText, t.scrollWidth, t.parentElement.clientWidth])};")
    finally:
        browser.set_window_size(size["width"], size["height"])
    for width, state in states.items():
        assert state["tables"] >= 12, (width, state)
        assert state["page"] <= state["view"], (width, state)
        assert state["hiding"] == [], (width, state["hiding"])
    assert states[1600]["body"] > 1300 and states[1100]["body"] < 1100, states
    # A 3D view per world variant; lazy's trajectory is eager's (equal cost), and the legend
    # says so.
    views = sorted(p.name for p in (tmp_path / "out" / "report").glob("view_*.html"))
    assert views == ["view_forest_density=0.05.html", "view_forest_density=0.1.html"], views
    open_view(browser, tmp_path / "out" / "report" / views[0])
    legend = browser.execute_script("return document.body.innerText")
    assert legend.startswith("wide: forest (density=0.05)\n"), legend
    assert "lazy: trajectory (the same as eager's)" in legend, legend
    # Three planners share the view, each in its colour of the report's figures; the trees'
    # edge states in the figures' colours, and no tree shown until asked for.
    colours = plots.planner_colours(["eager", "lazy", "tgk"])
    for planner in ("eager", "lazy", "tgk"):
        assert swatches(browser, f"q0-trajectory-{planner}") == [colours[planner]]
    for planner in ("eager", "lazy"):
        assert swatches(browser, f"q0-tree-{planner}-full") == [data.EDGE_COLOURS["full"]]
    trees = browser.execute_script(
        "return [...document.querySelectorAll('#layers input')].filter(i => i.id.includes("
        "'-tree-')).map(i => i.checked)")
    assert trees and not any(trees)
