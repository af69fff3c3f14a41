"""docs/figures/report.png: a screenshot of the demo's HTML report in headless chromium (Debian's chromium and its
driver, as tests/test_report_browser.py uses them).

    make demo                                    # spherestep-out/report.html
    python scripts/report_screenshot.py [REPORT.html] [-o docs/figures/report.png] [--step 15]

One sheet, top to bottom: the motor in 3-D, the resolution histogram, the commutation view at ``--step`` of the
turn (the slider clicked there, as a reader would), and the drives section — the turn driven three ways on both
models, the relay plan on the design's model and the servo against the model's known error (the robustness line).
"""

from __future__ import annotations

import argparse
import io
import sys
import tempfile
import time
from pathlib import Path

from PIL import Image

ROOT = Path(__file__).resolve().parents[1]
CHROMIUM, CHROMEDRIVER = "/usr/bin/chromium", "/usr/bin/chromedriver"
WINDOW = (1300, 1100)
PARTS = ("motor3d", "resolution", "commutation", "section-drives")


def _browser(profile: str):
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--no-first-run",
                "--disable-background-networking", "--disable-component-update", "--disable-sync",
                "--enable-unsafe-swiftshader", f"--window-size={WINDOW[0]},{WINDOW[1]}", f"--user-data-dir={profile}"):
        options.add_argument(arg)
    browser = webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)
    browser.set_page_load_timeout(120)
    return browser


def _shot(driver, element_id: str) -> Image.Image:
    element = driver.find_element("id", element_id)
    driver.execute_script("arguments[0].scrollIntoView({block: 'center'})", element)
    time.sleep(0.3)
    return Image.open(io.BytesIO(element.screenshot_as_png)).convert("RGB")


def _drawn(driver) -> bool:
    return driver.execute_script(
        "var g = Array.from(document.querySelectorAll('.plotly-graph-div'));"
        "return g.length > 0 && g.every(function (gd) { return gd._fullLayout && !gd._transitioning; });")


def screenshot(report: Path, out: Path, step: int) -> int:
    """Write the sheet of ``report`` to ``out``; returns the commutation step shown."""
    from selenium.webdriver.common.action_chains import ActionChains

    with tempfile.TemporaryDirectory() as profile:
        driver = _browser(profile)
        try:
            driver.get(report.resolve().as_uri())
            deadline = time.time() + 120
            while not _drawn(driver):
                if time.time() > deadline:
                    raise RuntimeError("the report's plots did not finish drawing within 120 s")
                time.sleep(0.3)
            gd = driver.find_element("id", "commutation")
            steps = driver.execute_script("return arguments[0]._fullLayout.sliders[0].steps.length", gd)
            driver.execute_script("arguments[0].scrollIntoView({block: 'center'})", gd)
            rail = driver.find_element("css selector", "#commutation .slider-rail-rect")
            width = rail.size["width"]
            shown = 0
            for _ in range(8):  # click along the rail until the slider stands at the step asked for
                offset = int(round(width * (min(step, steps - 1) / max(steps - 1, 1) - 0.5)))
                ActionChains(driver).move_to_element_with_offset(rail, offset, 0).click().perform()
                time.sleep(0.6)
                shown = driver.execute_script("return arguments[0]._fullLayout.sliders[0].active", gd)
                if shown == step:
                    break
                width += 2 * (step - shown)  # the rail's ends are padded: nudge the scale
            time.sleep(1.0)  # let the 3-D scene redraw
            parts = [_shot(driver, name) for name in PARTS]
        finally:
            driver.quit()
    sheet = Image.new("RGB", (max(p.width for p in parts), sum(p.height for p in parts)), "white")
    y = 0
    for p in parts:
        sheet.paste(p, (0, y))
        y += p.height
    sheet.thumbnail((1000, 10_000))
    tmp = out.with_suffix(".tmp.png")
    sheet.save(tmp)
    tmp.replace(out)
    return int(shown)


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("report", nargs="?", type=Path, default=ROOT / "spherestep-out" / "report.html")
    ap.add_argument("-o", "--out", type=Path, default=ROOT / "docs" / "figures" / "report.png")
    ap.add_argument("--step", type=int, default=15)
    args = ap.parse_args(argv)
    if not args.report.exists():
        print(f"report_screenshot: {args.report} missing: run `make demo` first", file=sys.stderr)
        return 2
    shown = screenshot(args.report, args.out, args.step)
    print(f"wrote {args.out} (commutation at step {shown})")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
