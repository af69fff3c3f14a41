"""The HTML report in a real browser: Debian's chromium, headless, driven by selenium.

It loads from a file:// URL with no console errors and no network request but the file itself, the 3-D
view renders the rotor (red and blue magnets on a grey sphere), and moving the step slider changes the
Fig. 10 view, the 3-D view and the highlighted plan row. ``make browser`` (a dependency of ``make test``)
installs chromium and chromium-driver when they are missing and it runs as root. Set
``SPHERESTEP_REPORT_SCREENSHOT=docs/figures/report.png`` to keep a screenshot of the page for the docs.
"""

import io
import json
import math
import os
import shutil
import subprocess
import time

import numpy as np
import pytest
from PIL import Image

from spherestep.commutation import about_axis, plan_geometric
from spherestep.report import write_report

pytestmark = pytest.mark.slow  # the heaviest module-wide: make check leaves it out

CHROMIUM, CHROMEDRIVER = "/usr/bin/chromium", "/usr/bin/chromedriver"
WINDOW = (1300, 1100)
AXIS = np.array([1.0, 0.5, 2.0])


def _browser_available() -> str | None:
    """None when chromium and chromedriver are there (installing them as root if need be), else why not."""
    if os.path.exists(CHROMIUM) and os.path.exists(CHROMEDRIVER):
        return None
    if os.geteuid() != 0 or shutil.which("apt-get") is None:
        return ("chromium and chromium-driver are not installed and this user cannot install them: "
                "run `sudo make browser`")
    env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
    done = subprocess.run("apt-get update -qq && apt-get install -y -qq chromium chromium-driver", shell=True,
                          env=env, capture_output=True, text=True)
    if done.returncode or not (os.path.exists(CHROMIUM) and os.path.exists(CHROMEDRIVER)):
        pytest.fail(f"installing chromium failed: {done.stderr.strip()[-500:]}")
    return None


@pytest.fixture(scope="module")
def driver(tmp_path_factory):
    reason = _browser_available()
    if reason:
        pytest.skip(reason)
    webdriver = pytest.importorskip("selenium.webdriver")
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--no-first-run",
                "--disable-background-networking", "--disable-component-update", "--disable-sync",
                "--enable-unsafe-swiftshader",  # WebGL in software, for the 3-D views
                f"--window-size={WINDOW[0]},{WINDOW[1]}", f"--user-data-dir={tmp_path_factory.mktemp('chromium')}"):
        options.add_argument(arg)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL", "performance": "ALL"})
    browser = webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)
    browser.set_page_load_timeout(60)
    yield browser
    browser.quit()


@pytest.fixture(scope="module")
def page(driver, proto, proto_metrics, tmp_path_factory):
    """The report of a 20-step quarter turn, loaded; returns (url, browser log, network requests)."""
    start = proto.states().rotations[int(proto.states().nearest(np.eye(3))[1].ravel()[0])]
    plan = plan_geometric(proto, about_axis(AXIS, math.pi / 2, 20, start=start))
    path = tmp_path_factory.mktemp("page") / "report.html"
    write_report(path, proto, proto_metrics, plan, axis=AXIS, seed=7)
    driver.get_log("performance")  # drop what the browser did before the report (its start page)
    url = path.as_uri()
    driver.get(url)
    deadline = time.time() + 30
    while not driver.execute_script(
            "return Array.from(document.querySelectorAll('.plotly-graph-div'))"
            ".every(function (gd) { return gd._fullLayout && !gd._transitioning; }) && "
            "document.querySelectorAll('.plotly-graph-div').length === 3"):
        assert time.time() < deadline, "the plots did not finish drawing within 30 s"
        time.sleep(0.2)
    requests = [json.loads(entry["message"])["message"] for entry in driver.get_log("performance")]
    # the report's own requests (its document's): under load the browser's start page can still be fetching its
    # chrome:// resources when the report loads (seen at load 20), and those are not the report's
    urls = [r["params"]["request"]["url"] for r in requests if r["method"] == "Network.requestWillBeSent"
            and r["params"].get("documentURL") == url]
    return url, driver.get_log("browser"), urls


def screenshot(driver, element_id: str) -> Image.Image:
    element = driver.find_element("id", element_id)
    driver.execute_script("arguments[0].scrollIntoView({block: 'center'})", element)
    return Image.open(io.BytesIO(element.screenshot_as_png)).convert("RGB")


def crop_to(driver, image: Image.Image, element_id: str, box_js: str) -> Image.Image:
    """``image`` of the element cropped to ``[left, top, width, height]`` (CSS px) from ``box_js``."""
    ratio = image.width / driver.execute_script(f"return document.getElementById('{element_id}').offsetWidth")
    left, top, width, height = driver.execute_script(box_js)
    return image.crop(tuple(int(round(v * ratio)) for v in (left, top, left + width, top + height)))


def scene_box(element_id: str) -> str:
    """JS for the box of the element's 3-D scene, from its domain in the plot area."""
    return (f"var f = document.getElementById('{element_id}')._fullLayout, s = f.scene.domain;"
            "return [f._size.l + s.x[0] * f._size.w, f._size.t + (1 - s.y[1]) * f._size.h,"
            "(s.x[1] - s.x[0]) * f._size.w, (s.y[1] - s.y[0]) * f._size.h];")


def painted(image: Image.Image) -> tuple[float, int, float, float]:
    """Fraction of non-white pixels, distinct colours, fractions of red (north) and blue (south) pixels."""
    a = np.asarray(image).astype(int)
    r, g, b = a[..., 0], a[..., 1], a[..., 2]
    colours = len(np.unique(a.reshape(-1, 3), axis=0))
    return (float(np.mean(a.min(axis=-1) < 235)), colours, float(np.mean((r > g + 50) & (r > b + 50))),
            float(np.mean((b > r + 40) & (b > g + 10))))


def test_loads_offline_without_console_errors(page):
    url, log, requests = page
    assert [e for e in log if e["level"] == "SEVERE"] == []
    assert requests and set(requests) == {url}, requests


def test_3d_view_renders_the_rotor(driver, page):
    image = screenshot(driver, "motor3d")
    scene = crop_to(driver, image, "motor3d", scene_box("motor3d"))
    ink, colours, red, blue = painted(scene)
    assert ink > 0.1 and colours > 500, (ink, colours)  # a shaded sphere, not a blank canvas
    assert red > 0.005 and blue > 0.003, (red, blue)  # magnets of both polarities


def test_slider_moves_the_commutation(driver, page):
    from selenium.webdriver.common.action_chains import ActionChains

    gd = driver.find_element("id", "commutation")
    box2d = ("var f = document.getElementById('commutation')._fullLayout;"
             "return [f.xaxis._offset, f.yaxis._offset, f.xaxis._length, f.yaxis._length];")
    box3d = scene_box("commutation")
    before = screenshot(driver, "commutation")
    fig10_before = crop_to(driver, before, "commutation", box2d)
    view3d_before = crop_to(driver, before, "commutation", box3d)
    assert painted(fig10_before)[0] > 0.02 and painted(view3d_before)[0] > 0.1
    assert driver.execute_script("return arguments[0]._fullLayout.sliders[0].active", gd) == 0
    # click the slider's rail three quarters along: about step 15 of 20
    rail = driver.find_element("css selector", "#commutation .slider-rail-rect")
    ActionChains(driver).move_to_element_with_offset(rail, rail.size["width"] // 4, 0).click().perform()
    deadline = time.time() + 10
    while driver.execute_script("return arguments[0]._fullLayout.title.text", gd).startswith("step 0 "):
        assert time.time() < deadline, "the slider did not change the step shown"
        time.sleep(0.1)
    time.sleep(0.5)  # let the 3-D scene redraw
    active = driver.execute_script("return arguments[0]._fullLayout.sliders[0].active", gd)
    assert 12 <= active <= 18
    assert driver.execute_script("return arguments[0]._fullLayout.title.text", gd).startswith(f"step {active} of 20")
    assert driver.execute_script("return document.querySelector('tr.current').id") == f"step-{active}"
    after = screenshot(driver, "commutation")
    for box, old in ((box2d, fig10_before), (box3d, view3d_before)):
        new = np.asarray(crop_to(driver, after, "commutation", box)).astype(int)
        changed = np.mean(np.abs(new - np.asarray(old).astype(int)).max(axis=-1) > 40)
        assert changed > 0.003, changed
    keep = os.environ.get("SPHERESTEP_REPORT_SCREENSHOT")
    if keep:
        parts = [screenshot(driver, "motor3d"), screenshot(driver, "resolution"), after]
        width = max(p.width for p in parts)
        sheet = Image.new("RGB", (width, sum(p.height for p in parts)), "white")
        y = 0
        for p in parts:
            sheet.paste(p, (0, y))
            y += p.height
        sheet.thumbnail((1000, 10_000))
        sheet.save(keep)
