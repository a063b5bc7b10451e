"""The HTML report in a real browser (headless Chromium): renders without console messages,
every figure is in the DOM, and screenshots 1400 px wide show a rich page that uses the width
(figures side by side) and stays short."""

from __future__ import annotations

import re
import shutil
import subprocess

import numpy as np
import pytest

pytest.importorskip("matplotlib", reason="the report needs matplotlib (report/test extra)")

from test_report import section_ids, svg_count, synthetic_result  # noqa: E402

from robocal.report.html import write_report  # noqa: E402

pytestmark = pytest.mark.slow  # a browser start per test: `make test-slow`

BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--hide-scrollbars", "--enable-logging=stderr", "--v=0"]
CONSOLE = re.compile(r":CONSOLE[:(]\d*\)?\] (.*)")


@pytest.fixture(scope="module")
def browser() -> str:
    for name in BROWSERS:
        path = shutil.which(name)
        if path:
            return path
    pytest.skip("no Chromium found (Debian: apt-get install chromium; `make test-slow` installs it where "
                "apt-get is available)")


def run_browser(browser: str, tmp_path, url: str, *extra: str) -> subprocess.CompletedProcess:
    profile = tmp_path / f"profile{len(list(tmp_path.glob('profile*')))}"
    return subprocess.run([browser, *FLAGS, f"--user-data-dir={profile}", *extra, url],
                          capture_output=True, text=True, timeout=120, check=False)


def console_messages(stderr: str) -> list[str]:
    return [m.group(1) for m in CONSOLE.finditer(stderr)]


def test_console_detection_works(browser, tmp_path):
    """Negative control: a page with a script error and a blocked network load is caught."""
    page = tmp_path / "bad.html"
    page.write_text("<!DOCTYPE html><html><head><meta http-equiv='Content-Security-Policy' "
                    "content=\"default-src 'none'\"></head><body><img src='http://192.0.2.1/x.png'>"
                    "</body></html>")
    messages = console_messages(run_browser(browser, tmp_path, page.as_uri(), "--dump-dom").stderr)
    assert any("Content Security Policy" in m for m in messages), messages


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    path = tmp_path_factory.mktemp("report") / "report.html"
    write_report(synthetic_result(11, n_poses=80), path)
    return path


def test_report_renders_without_console_messages(browser, tmp_path, report):
    proc = run_browser(browser, tmp_path, report.as_uri(), "--dump-dom")
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert console_messages(proc.stderr) == []
    dom = proc.stdout
    source = report.read_text(encoding="utf-8")
    assert svg_count(dom) == svg_count(source) == 7
    assert section_ids(dom) == section_ids(source)
    assert len(re.findall(r"<table", dom)) >= 8


WIDTH = 1400  # the screen width the layout is checked at
TALL = 7000  # a window taller than the synthetic report, so the screenshot shows all of it


def screenshot(browser: str, tmp_path, page, height: int = TALL) -> np.ndarray:
    from PIL import Image

    shot = tmp_path / "shot.png"
    proc = run_browser(browser, tmp_path, page.as_uri(), f"--screenshot={shot}",
                       f"--window-size={WIDTH},{height}")
    assert shot.exists(), proc.stderr[-2000:]
    assert console_messages(proc.stderr) == []
    return np.asarray(Image.open(shot).convert("RGB"))


def series_masks(img: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pixels of the 'before' (orange) and 'after' (green) series colours."""
    r, g, b = (img[..., k].astype(int) for k in range(3))
    return (r - b > 80) & (r > g + 30), (g - r > 60) & (g > b)


def page_height(img: np.ndarray) -> int:
    """The last row of the page holding anything but background and white."""
    return int(np.nonzero((img[:, 40:WIDTH - 40].min(axis=2) < 230).any(axis=1))[0].max()) + 1


def test_screenshot_shows_the_plots_across_the_width(browser, tmp_path, report):
    img = screenshot(browser, tmp_path, report)
    assert img.shape == (TALL, WIDTH, 3)
    colours = np.unique(img.reshape(-1, 3) // 8, axis=0)  # 32 levels per channel
    assert len(colours) > 300, f"only {len(colours)} distinct colours: blank or unstyled page"
    orange, green = series_masks(img)
    assert orange.sum() > 5000 and green.sum() > 2000, (orange.sum(), green.sum())
    # the figures use the width: two of them side by side, the 'after' series drawn in both
    # halves of the same rows with the grid's gutter between them blank (one wide figure would
    # draw across the middle)
    half = WIDTH // 2
    ink = img.min(axis=2) < 200
    left, right = green[:, 40:half - 20].sum(axis=1) > 3, green[:, half + 20:WIDTH - 40].sum(axis=1) > 3
    side_by_side = left & right & ~ink[:, half - 10:half + 10].any(axis=1)
    assert side_by_side.sum() > 100, f"{side_by_side.sum()} rows with figures side by side"
    quarter = ink[:, int(WIDTH * 0.75):WIDTH - 40].any(axis=0).mean()
    assert quarter > 0.9, f"only {quarter:.0%} of the right quarter's columns are drawn on"
    # a page that reads at a glance: the 8-section report in well under the 8,000 px of one column
    height = page_height(img)
    assert height < 6500, height


def _demo_report(tmp_path_factory):
    from robocal.demo import run_demo

    return run_demo(tmp_path_factory.mktemp("demo"), quiet=True)["report"]


def _meca500_report(tmp_path_factory):
    from robots import require_datasets

    from robocal import Robot, calibrate
    from robocal.data.datasets import meca500

    cal, val = meca500(require_datasets())
    result = calibrate(Robot.from_catalog("meca500"), cal, validation=val)
    return write_report(result.to_dict(), tmp_path_factory.mktemp("meca") / "report.html")


@pytest.mark.parametrize("make, sections", [
    (_demo_report, ["summary", "errors", "predicted-accuracy", "parameters", "priors", "model-selection",
                    "identifiability", "correlation", "rejected", "history"]),
    (_meca500_report, ["summary", "errors", "predicted-accuracy", "parameters", "priors", "model-selection",
                       "identifiability", "correlation", "history"]),
], ids=["demo", "real-meca500"])
def test_real_reports_open_with_every_section(browser, tmp_path, tmp_path_factory, make, sections):
    """The demo's report and a real Meca500 calibration's: no console message, every section and
    figure rendered, a screenshot that is not blank."""
    path = make(tmp_path_factory)
    proc = run_browser(browser, tmp_path, path.as_uri(), "--dump-dom")
    assert proc.returncode == 0 and console_messages(proc.stderr) == []
    assert section_ids(proc.stdout) == sections
    assert svg_count(proc.stdout) == svg_count(path.read_text(encoding="utf-8")) >= 7
    img = screenshot(browser, tmp_path, path, height=3000)
    assert len(np.unique(img.reshape(-1, 3) // 8, axis=0)) > 300


def test_campaign_page_renders_without_console_messages(browser, tmp_path):
    from robocal import Robot, plan_poses
    from robocal.report.campaign import render_campaign

    plan = plan_poses(Robot.from_catalog("meca500"), 14, smr=[0.01, 0.0, 0.03], n_candidates=400,
                      starts=1, curve=(11, 20))
    page = tmp_path / "campaign.html"
    page.write_text(render_campaign(plan.to_dict()), encoding="utf-8")
    proc = run_browser(browser, tmp_path, page.as_uri(), "--dump-dom")
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert console_messages(proc.stderr) == []
    assert svg_count(proc.stdout) == svg_count(page.read_text(encoding="utf-8")) == 2
    assert section_ids(proc.stdout) == ["summary", "curve", "identifiability", "poses"]


PHONE = 390  # px: a phone's screen width
LAPTOP = 1280  # px: a laptop's, where two columns of half width sit side by side


def _page_width(browser: str, tmp_path, report, width: int) -> int:
    """The report's full scroll width (px) when shown ``width`` px wide: in an iframe of that width
    (headless Chromium's window is at least 500 px wide), read by the outer page's script."""
    probe = tmp_path / "probe.html"
    probe.write_text(f"<!DOCTYPE html><html><body style='margin:0'><iframe id='f' src='{report.as_uri()}' "
                     f"style='width:{width}px;height:900px;border:0'></iframe><script>"
                     "document.getElementById('f').addEventListener('load',e=>document.body.setAttribute("
                     "'data-width',e.target.contentDocument.documentElement.scrollWidth))</script></body></html>",
                     encoding="utf-8")
    proc = run_browser(browser, tmp_path, probe.as_uri(), "--dump-dom", "--allow-file-access-from-files",
                       "--window-size=1400,900", "--virtual-time-budget=5000")
    found = re.search(r'data-width="(\d+)"', proc.stdout)
    assert found, proc.stderr[-2000:]
    return int(found.group(1))


def test_report_fits_a_phone(browser, tmp_path, report):
    assert _page_width(browser, tmp_path, report, PHONE) <= PHONE + 10
    assert _page_width(browser, tmp_path, report, WIDTH) <= WIDTH + 10  # and the wide layout still fits
    assert _page_width(browser, tmp_path, report, LAPTOP) <= LAPTOP + 10  # tables scroll in half columns


A4_PAGES = 4  # a typical calibration's report prints on at most this many A4 pages (issue 48)
PDF_PAGE = re.compile(rb"/Type\s*/Page(?![s\w])")


def _typical_report(tmp_path_factory):
    """The tutorial's calibration: 20 planned-size poses of an IRB 2600, 100 held-out poses."""
    from robocal import Robot, calibrate, simulate_tracker

    robot = Robot.from_catalog("abb_irb2600")
    cal = simulate_tracker(robot, 20, seed=7)
    val = simulate_tracker(cal.truth, 100, seed=8, as_is=True)
    result = calibrate(robot, cal.data, validation=val.data)
    return write_report(result.to_dict(), tmp_path_factory.mktemp("typical") / "report.html")


@pytest.mark.parametrize("make", [_typical_report, _demo_report], ids=["tutorial", "demo"])
def test_a_typical_calibration_prints_on_few_a4_pages(browser, tmp_path, tmp_path_factory, make):
    """Printed to PDF by the browser: A4 pages (the page's @page rule), at most `A4_PAGES`."""
    path = make(tmp_path_factory)
    pdf = tmp_path / "report.pdf"
    proc = run_browser(browser, tmp_path, path.as_uri(), f"--print-to-pdf={pdf}", "--no-pdf-header-footer")
    assert pdf.exists(), proc.stderr[-2000:]
    data = pdf.read_bytes()
    pages = len(PDF_PAGE.findall(data))
    assert 1 <= pages <= A4_PAGES, pages
    box = re.search(rb"/MediaBox\s*\[\s*0\s+0\s+([\d.]+)\s+([\d.]+)\s*\]", data)
    assert box and abs(float(box.group(1)) - 595.3) < 2 and abs(float(box.group(2)) - 841.9) < 2, box
