"""The 3D viewer in headless Chromium (Debian's chromium and chromedriver, through
Selenium): the page kinolab writes renders a canvas that is not blank, each layer's
checkbox toggles what is drawn, and a flight's replay grows its known map."""

import os
import shutil
import subprocess
from pathlib import Path

import pytest
from selenium import webdriver
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import WebDriverWait

SOURCE_DIR = Path(os.environ.get("KINOLAB_SOURCE_DIR", Path(__file__).resolve().parents[2]))
BINARY = os.environ.get("KINOLAB_BIN", str(SOURCE_DIR / "build" / "framework" / "kinolab"))
WORLD = SOURCE_DIR / "tests" / "support" / "small_forest.yaml"


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
    # One planner alone: its tree is shown, every state a shade of the trajectory's hue.
    checked = browser.execute_script(
        "return [...document.querySelectorAll('#layers input[type=checkbox]')]"
        ".filter(i => i.id.includes('-tree-')).map(i => i.checked)")
    assert checked and all(checked)
    assert same_hue(hues(browser, "q0-tree-lazy_mp_astar-"), hues(browser, "q0-trajectory-")[0])
    # Without obstacles or trees, only the trajectory over the floor remains; then the floor.
    for layer in layers:
        if layer != "q0-trajectory-lazy_mp_astar":
            click(browser, layer)
    alone = painted(browser)
    assert alone < everything[0]
    assert click(browser, "q0-trajectory-lazy_mp_astar")[0] < alone


def hues(browser, prefix):
    """The hues (0-359) of the legend swatches of the layers whose ids start with `prefix`."""
    values = browser.execute_script(
        "return [...document.querySelectorAll('#layers input')].filter(i => i.id.startsWith("
        "'layer-' + arguments[0])).map(i => getComputedStyle(i.nextSibling).backgroundColor)",
        prefix)
    def hue(css):
        import colorsys
        r, g, b = (int(v) / 255 for v in css[css.index("(") + 1:css.index(")")].split(",")[:3])
        return round(colorsys.rgb_to_hsv(r, g, b)[0] * 360) % 360
    found = [hue(v) for v in values]
    assert found, f"no layer starts with {prefix}"
    return found


def same_hue(shades, hue):
    """Every shade within 3 degrees of `hue` (8-bit channels round a shade's hue a little)."""
    return all(min(abs(h - hue), 360 - abs(h - hue)) <= 3 for h in shades)


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
worlds: [{{id: forest, spec: {world}}}]
queries:
  random: {{count: 6, min_distance: 3, max_distance: 8}}
planners:
  - id: eager
    type: eager_mp_astar
  - id: lazy
    type: lazy_mp_astar
  - id: tgk
    type: rrtstar_ceres
reproduces: {{paper: lazy_mp_astar_paper, rows: {{eager: MP-A*, lazy: Lazy, tgk: TGK}}}}
budget: {{time: 5, memory_mb: 2048}}
timing: {{warmup: 0, repeats: 1}}
store: {{trajectories: true, trees: 1}}
sweep:
  grid:
    planners.lazy.params.edge_samples: [2, 20]
"""


def test_a_report_fits_a_1100_pixel_window(browser, tmp_path):
    """The report of a three-planner sweep with the paper's table (its widest tables) read at
    1,100 px: the page never scrolls sideways; a table still wider than its column scrolls in
    its own box."""
    config = tmp_path / "wide.yaml"
    config.write_text(REPORT_EXPERIMENT.format(world=WORLD))
    kinolab("run", config, "--out", tmp_path / "out", "-j", "2", tmp_path=tmp_path)
    kinolab("report", tmp_path / "out", tmp_path=tmp_path)
    size = browser.get_window_size()
    try:
        browser.set_window_size(1100, 900)
        browser.get((tmp_path / "out" / "report" / "index.html").resolve().as_uri())
        WebDriverWait(browser, 60).until(
            lambda b: b.execute_script("return document.readyState") == "complete")
        state = browser.execute_script(
            "const page = document.documentElement;"
            "return {page: page.scrollWidth, view: page.clientWidth,"
            " tables: document.querySelectorAll('table').length,"
            " loose: [...document.querySelectorAll('table')]"
            "   .filter(t => !t.closest('.wide') && t.getBoundingClientRect().right >"
            "     page.clientWidth).length};")
    finally:
        browser.set_window_size(size["width"], size["height"])
    assert state["tables"] >= 8
    assert state["page"] <= state["view"], state
    assert state["loose"] == 0, state
    # Its 3D view: lazy's trajectory is eager's (equal cost), and the legend says so.
    open_view(browser, tmp_path / "out" / "report" / "view_forest.html")
    legend = browser.execute_script("return document.body.innerText")
    assert "lazy: trajectory (the same as eager's)" in legend, legend
    # Three planners share the view: one hue each, their trees' shades included, and no
    # tree shown until asked for.
    trajectory_hues = {planner: hues(browser, f"q0-trajectory-{planner}")[0]
                       for planner in ("eager", "lazy", "tgk")}
    assert len(set(trajectory_hues.values())) == 3, trajectory_hues
    for planner in ("eager", "lazy"):
        assert same_hue(hues(browser, f"q0-tree-{planner}-"), trajectory_hues[planner])
    trees = browser.execute_script(
        "return [...document.querySelectorAll('#layers input')].filter(i => i.id.includes("
        "'-tree-')).map(i => i.checked)")
    assert trees and not any(trees)
