"""holecli.quality.html in a real browser: Debian's chromium, headless, renders the report of a real lot.

Three runs of chromium (about 1-2 s each): a screenshot (the page is painted, with its colours), the
DOM after rendering (the tables and charts are there), and a page with a deliberate error that the
console check must catch (so that its silence on the report means something).
"""

import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys
from html.parser import HTMLParser

import pytest

from holecli.quality.html import html_report
from holecli.quality.lot import lot_from_records

CHROMIUM = shutil.which("chromium") or ("/usr/bin/chromium" if os.access("/usr/bin/chromium", os.X_OK) else None)

pytestmark = pytest.mark.skipif(CHROMIUM is None, reason="Debian's chromium is not installed (scripts/setup.sh "
                                                         "installs it): the HTML report cannot be rendered")

# What chromium's log (--enable-logging=stderr --v=0) says of a page's console: every console message
# (a script's error, a blocked resource) is a line with CONSOLE; older versions say "Refused to ..."
# for what the Content-Security-Policy blocks.
_CONSOLE = re.compile(r"CONSOLE|Uncaught|Refused to|violates the following Content Security Policy")
_RUN_SECONDS = 60


def _chromium(url, profile, *options):
    """One headless chromium run on ``url`` (its stdout, stderr and exit code)."""
    command = [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
               f"--user-data-dir={profile}", "--enable-logging=stderr", "--v=0", *options, url]
    return subprocess.run(command, capture_output=True, text=True, timeout=_RUN_SECONDS)


def _console_lines(stderr):
    return [line for line in stderr.splitlines() if _CONSOLE.search(line)]


@pytest.fixture(scope="module")
def report(repo_root, tmp_path_factory):
    """The report of a simulated lot of 4 panels (part 2's C1 0.1 mm large, part 3's L1 not drilled),
    written to a file, and its lot."""
    folder = tmp_path_factory.mktemp("browser")
    env = dict(os.environ, PYTHONPATH=str(repo_root))
    holecli = [sys.executable, "-m", "holecli"]
    subprocess.run(holecli + ["simulate", "lot", str(folder / "lot"), "--parts", "4", "--panel",
                              "sample_clouds/panel.toml", "--spacing", "0.2", "--defect", "2/C1=diameter:+0.1",
                              "--defect", "3/L1=missing", "-q"], cwd=repo_root, env=env, check=True, timeout=300)
    subprocess.run(holecli + ["batch", str(folder / "lot"), "--spec", "sample_clouds/panel_tolerances.toml",
                              "-o", str(folder / "shift.jsonl"), "-q"], cwd=repo_root, env=env, timeout=300)
    lines = (folder / "shift.jsonl").read_text().splitlines()
    records = sorted((json.loads(line) for line in lines), key=lambda record: record["file"])
    lot = lot_from_records({"record": r, "source": f"shift.jsonl:{n}"} for n, r in enumerate(records, 1))
    views = {}
    if importlib.util.find_spec("matplotlib") is not None:  # the scan's pictures: the extra plot
        from holecli.cli.report import scan_views

        views = scan_views(lot, 50)
    path = folder / "report.html"
    path.write_text(html_report(lot, title="Panel lot", scan_views=views), encoding="utf-8")
    return path, lot, views


class _Census(HTMLParser):
    """Counts of the rendered DOM's elements by tag, by (tag, class) and by (tag, class attribute)."""

    def __init__(self):
        super().__init__()
        self.tags, self.classes, self.attributes = {}, {}, {}

    def handle_starttag(self, tag, attrs):
        self.tags[tag] = self.tags.get(tag, 0) + 1
        whole = (tag, dict(attrs).get("class"))
        self.attributes[whole] = self.attributes.get(whole, 0) + 1
        for name in (dict(attrs).get("class") or "").split():
            self.classes[(tag, name)] = self.classes.get((tag, name), 0) + 1

    handle_startendtag = handle_starttag


def test_the_report_renders_to_a_painted_png_without_console_errors(report, tmp_path):
    image = pytest.importorskip("PIL.Image", reason="Pillow (the plot extra) reads the screenshot")
    path, _, _ = report
    png = tmp_path / "page.png"
    run = _chromium(path.as_uri(), tmp_path / "profile", f"--screenshot={png}", "--window-size=1280,2000")
    assert run.returncode == 0, run.stderr[-2000:]
    assert _console_lines(run.stderr) == []
    with image.open(png) as picture:
        assert picture.size == (1280, 2000)
        pixels = picture.convert("RGB")
        colours = pixels.getcolors(maxcolors=1 << 20)
    assert len(colours) > 200  # text, tables, badges and pictures, anti-aliased: not a blank page
    white = sum(count for count, colour in colours if colour == (255, 255, 255))
    assert white < 0.95 * 1280 * 2000
    present = {colour for count, colour in colours if count >= 50}
    # the verdicts' colours are painted: the pass and fail backgrounds of the summary and the tables
    assert (0xda, 0xfb, 0xe1) in present and (0xfd, 0xe2, 0xe1) in present


def test_the_rendered_dom_holds_the_tables_and_charts(report, tmp_path):
    path, lot, views = report
    run = _chromium(path.as_uri(), tmp_path / "profile", "--dump-dom")
    assert run.returncode == 0, run.stderr[-2000:]
    assert _console_lines(run.stderr) == []
    census = _Census()
    census.feed(run.stdout)
    assert census.tags.get("script", 0) == 0
    assert census.tags.get("img", 0) == len(views)  # the scan's pictures: data: PNGs the policy allows
    assert census.classes[("table", "holes")] == len(lot.measurements) == 4
    assert census.classes[("section", "key")] == len(lot.keys)
    assert census.classes[("figure", "individuals")] == census.classes[("figure", "moving_range")] == len(lot.keys)
    assert census.attributes[("figure", "fit")] == sum(len(m.record["holes"]) for m in lot.measurements)
    assert census.attributes.get(("figure", "fit scan"), 0) == len(views)
    assert census.tags["svg"] >= 3 * len(lot.keys) + 15
    assert census.tags["polyline"] >= 2 * len(lot.keys)
    assert census.classes[("td", "decision")] == len(lot.characteristics)
    assert census.attributes[("td", "decision fail")] == sum(c.decision == "fail" for c in lot.characteristics) == 2


def test_the_console_check_catches_a_blocked_script(report, tmp_path):
    # The report with a script put in: the page's Content-Security-Policy blocks it and the console says so.
    path, _, _ = report
    spoiled = tmp_path / "spoiled.html"
    spoiled.write_text(path.read_text(encoding="utf-8").replace(
        "</body>", '<script>document.title = "ran"; notAFunction();</script></body>'), encoding="utf-8")
    run = _chromium(spoiled.as_uri(), tmp_path / "profile", "--dump-dom")
    assert run.returncode == 0, run.stderr[-2000:]
    lines = _console_lines(run.stderr)
    assert lines and any("Content Security Policy" in line or "Refused to" in line for line in lines), run.stderr
    assert "<title>ran</title>" not in run.stdout  # blocked, not run
