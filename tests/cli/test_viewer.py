"""The interactive HTML page of a run (``mbdsl view``, ``simulate --html``).

The page is checked in a real browser (headless Chromium driven by
Selenium through chromedriver): it loads without console errors, holds its
frames, a click on the time slider moves the drawing, the positions it draws
are the result file's (interpolated to the frame's time, drawn by the same
scene geometry), and a screenshot shows the crank's colour where the crank
is in that frame and not where it is in another. Without a browser these
tests skip, saying how to install one.
"""

import shutil
import time
from pathlib import Path

import numpy as np
import pytest

import mbdsl
from mbdsl.cli.main import main
from mbdsl.graphics.scene import Scene
from mbdsl.graphics.viewer import write_html

from ..conftest import MODELS

CHROMIUM, DRIVER = shutil.which("chromium"), shutil.which("chromedriver")
INSTALL = ("no headless browser here: apt-get install -y chromium chromium-driver "
           "(Debian), and pip install selenium (the test extra)")


@pytest.fixture(scope="module")
def crank_page(tmp_path_factory):
    """The flexible slider crank run for 1 s, written as CSV, and its page."""
    folder = tmp_path_factory.mktemp("view")
    csv = folder / "fsc.csv"
    assert main(["simulate", str(MODELS / "flexible_slider_crank.mbd"), "--t-end", "1", "-q",
                 "-o", str(csv), "--html"]) == 0
    return csv, csv.with_suffix(".html")


def test_the_page_is_one_offline_file(crank_page):
    """Self-contained (plotly's script inside, nothing fetched), under 20 MB,
    with the run's summary and 200 frames."""
    _, page = crank_page
    text = page.read_text()
    assert page.stat().st_size < 20e6
    import re
    assert re.search(r"<script[^>]*\bsrc\s*=", text) is None      # no script fetched
    assert "Plotly.newPlot" in text or "Plotly.react" in text
    assert "window.mbdslViewer" in text and "\"frames\": 200" in text
    assert "flexible_slider_crank" in text and "iterations/step" in text


def test_a_chain_of_200_links(tmp_path):
    """A 200-link pendulum chain, 200 frames: under 20 MB, a few traces for
    all the links (not one per body)."""
    model = mbdsl.load(MODELS / "pendulum_chain.mbd", overrides={"N": 200})
    sol = mbdsl.simulate(model, method="hht-i3", h=1e-3, t_end=0.3, output_dt=2e-3)
    page = write_html(sol, tmp_path / "chain.html")
    assert page.stat().st_size < 20e6
    text = page.read_text()
    import json
    info = json.loads(text.split("window.mbdslViewer = ", 1)[1].split(";</script>", 1)[0])
    assert info["frames"] == 151 and len(info["traces"]) <= 25


def test_view_names_an_unknown_column(crank_page, capsys):
    csv, _ = crank_page
    assert main(["view", str(csv), "--y", "rod.bogus", "-o", str(csv.with_suffix(".x.html"))]) == 1
    assert "no column 'rod.bogus'" in capsys.readouterr().err


@pytest.fixture(scope="module")
def browser():
    if not (CHROMIUM and DRIVER):
        pytest.skip(INSTALL)
    webdriver = pytest.importorskip("selenium.webdriver", reason=INSTALL)
    from selenium.webdriver.chrome.service import Service
    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    for a in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
              "--window-size=1400,1000", "--force-device-scale-factor=1"):
        opts.add_argument(a)
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service(DRIVER), options=opts)
    yield driver
    driver.quit()


def _errors(driver):
    return [e for e in driver.get_log("browser") if e["level"] == "SEVERE"]


def _click_slider(driver, fraction):
    """Click the time slider's rail at ``fraction`` of its length; the frame shown."""
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By
    rail = driver.find_element(By.CSS_SELECTOR, ".slider-rail-rect")
    width = rail.rect["width"]
    ActionChains(driver).move_to_element_with_offset(rail, int((fraction - 0.5) * width),
                                                     0).click().perform()
    time.sleep(0.3)
    return driver.execute_script(
        "return document.getElementById('mechanism').layout.sliders[0].active")


def _drawn(driver, trace):
    """x, y the page draws for a trace (NaN gaps as NaN)."""
    x, y = driver.execute_script(
        "var gd = document.getElementById('mechanism');"
        f"return [Array.from(gd._fullData[{trace}].x), Array.from(gd._fullData[{trace}].y)];")
    return (np.array([np.nan if v is None else v for v in x], float),
            np.array([np.nan if v is None else v for v in y], float))


def _pixel(driver, x, y):
    """Page pixel (column, row) of the mechanism's world point (x, y) [m]."""
    return driver.execute_script(
        "var gd = document.getElementById('mechanism'), L = gd._fullLayout;"
        "var r = gd.getBoundingClientRect();"
        f"return [r.left + L.xaxis._offset + L.xaxis.l2p({x}),"
        f" r.top + L.yaxis._offset + L.yaxis.l2p({y})];")


def test_the_page_in_a_browser(browser, crank_page):
    """Load, no console errors; 200 frames; three clicks on the slider: the
    joints and the beam drawn where the result file puts them at the
    frame's time (to 1e-12 m); the crank's colour on a screenshot at the
    crank's mid-point, not there in another frame."""
    from io import BytesIO
    from PIL import Image
    csv, page = crank_page
    sol = mbdsl.load_solution(csv)
    browser.get(page.as_uri())
    time.sleep(1.0)
    assert _errors(browser) == []
    info = browser.execute_script("return window.mbdslViewer")
    frames = browser.execute_script(
        "return document.getElementById('mechanism')._transitionData._frames.length")
    assert info["frames"] == frames == 200
    scene = Scene(sol.model)
    q_at = [np.array([np.interp(t, sol.t, sol.q[:, j]) for j in range(sol.q.shape[1])])
            for t in info["times"]]
    joints = next(tr["trace"] for tr in info["traces"] if tr["style"] == "joint")
    beam = next(tr["trace"] for tr in info["traces"] if tr["style"] == "beam")
    crank_color = scene.colors["crank"]
    shown = []
    for fraction in (0.2, 0.5, 0.8):
        k = _click_slider(browser, fraction)
        assert abs(k - fraction * (frames - 1)) <= 2
        shown.append(k)
        coords = scene.coordinates(q_at[k])
        expected = np.vstack([c for c, item in zip(coords, scene.items) if item.kind == "joint"])
        x, y = _drawn(browser, joints)
        assert np.max(np.abs(x - expected[:, 0])) < 1e-12
        assert np.max(np.abs(y - expected[:, 1])) < 1e-12
        line = next(c for c, item in zip(coords, scene.items) if item.kind == "beam")
        x, y = _drawn(browser, beam)
        assert np.max(np.abs(x - line[:, 0])) < 1e-12 and np.max(np.abs(y - line[:, 1])) < 1e-12
    assert _errors(browser) == []
    # the screenshot: the crank's colour at its mid-point in the last frame shown
    crank = next(c for c, item in zip(scene.coordinates(q_at[shown[-1]]), scene.items)
                 if item.body == "crank")
    mid = crank.mean(axis=0)
    image = Image.open(BytesIO(browser.get_screenshot_as_png())).convert("RGB")
    want = np.array([int(crank_color[i:i + 2], 16) for i in (1, 3, 5)])

    def near(px):
        c, r = (int(round(v)) for v in px)
        patch = np.array([image.getpixel((c + i, r + j)) for i in (-2, 0, 2) for j in (-2, 0, 2)])
        return np.min(np.abs(patch - want).sum(axis=1)) < 60
    assert near(_pixel(browser, *mid))
    _click_slider(browser, 0.2)
    image = Image.open(BytesIO(browser.get_screenshot_as_png())).convert("RGB")
    assert not near(_pixel(browser, *mid))


def test_play_moves_the_frames(browser, tmp_path):
    """A 200-link chain's page plays: after play, the slider has moved on."""
    from selenium.webdriver.common.by import By
    model = mbdsl.load(MODELS / "pendulum_chain.mbd", overrides={"N": 200})
    sol = mbdsl.simulate(model, method="hht-i3", h=1e-3, t_end=0.3, output_dt=2e-3)
    page = write_html(sol, tmp_path / "chain.html")
    browser.get(page.as_uri())
    time.sleep(1.0)
    buttons = browser.find_elements(By.CSS_SELECTOR, ".updatemenu-button")
    next(b for b in buttons if "play x1" in b.text).click()
    time.sleep(1.5)
    k = browser.execute_script(
        "return document.getElementById('mechanism').layout.sliders[0].active")
    assert k > 5
    assert _errors(browser) == []


def test_a_spatial_page_in_a_browser(browser, tmp_path):
    """The spatial slider-crank's page: it loads without a script error, its
    mechanism is a 3D scene of scatter3d traces, and its slider moves the
    bodies (the slider's centre-of-mass marker leaves where it started; the
    crank's sits on its axis); it does not play by itself on load."""
    sol = mbdsl.simulate(mbdsl.load(MODELS / "spatial_slider_crank.mbd"), t_end=0.5)
    page = write_html(sol, tmp_path / "crank.html", max_frames=50)
    browser.get(page.as_uri())
    time.sleep(1.0)
    assert not _errors(browser)
    info = browser.execute_script("return window.mbdslViewer")
    kinds = browser.execute_script(
        "var gd = document.getElementById('mechanism');"
        "return window.mbdslViewer.traces.map(t => gd._fullData[t.trace].type);")
    assert set(kinds) == {"scatter3d"} and info["frames"] == 50
    cm = [t["trace"] for t in info["traces"] if t["style"] == "cm"][-1]     # the slider's
    where = ("var gd = document.getElementById('mechanism');"
             f"return Array.from(gd._fullData[{cm}].x);")
    first = browser.execute_script(where)
    time.sleep(1.0)
    assert browser.execute_script(where) == first            # no autoplay
    _click_slider(browser, 0.6)
    assert browser.execute_script(where) != first
