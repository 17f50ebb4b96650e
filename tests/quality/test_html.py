"""holecli.quality.html: the inspection report of a real lot's batch records, parsed back."""

import base64
import copy
import json
import os
import re
import subprocess
import sys
from html.parser import HTMLParser

import pytest

import holecli
from holecli.quality import spc
from holecli.quality.html import CONTENT_SECURITY_POLICY, REASON_WORDS, html_report, tur_words
from holecli.quality.lot import Lot, lot_from_records

GENERATED = "2026-12-04T06:00:00+00:00"


def _batch(repo_root, folder, *options):
    """The records of ``holecli batch`` over the simulated lot in ``folder``, in file order."""
    out = folder / f"shift{len(options)}.jsonl"
    env = dict(os.environ, PYTHONPATH=str(repo_root))
    batch = subprocess.run([sys.executable, "-m", "holecli", "batch", str(folder / "lot"), "--spec",
                            "sample_clouds/panel_tolerances.toml", "-o", str(out), "-q", *options],
                           cwd=repo_root, env=env, timeout=300)
    assert batch.returncode in (5, 6), batch.returncode  # a part out of tolerance (5) or undecided (6)
    return sorted((json.loads(line) for line in out.read_text().splitlines()), key=lambda record: record["file"])


@pytest.fixture(scope="module")
def folder(shift_lot):
    """The simulated lot of 4 panels (tests/conftest.py's shift_lot): part 2's C1 drilled 0.1 mm large,
    part 3's L1 not drilled, in ``lot/``."""
    return shift_lot["folder"]


@pytest.fixture(scope="module")
def records(repo_root, folder):
    """The lot's batch records checked against sample_clouds/panel_tolerances.toml (simple rule)."""
    return _batch(repo_root, folder)


@pytest.fixture(scope="module")
def guarded_records(repo_root, folder):
    """The same scans checked by the guarded rule (ISO 14253-1: U counts against the part)."""
    return _batch(repo_root, folder, "--decision-rule", "guarded")


def _lot(records):
    return lot_from_records({"record": record, "source": f"shift.jsonl:{n}"} for n, record in enumerate(records, 1))


@pytest.fixture(scope="module")
def lot(records):
    return _lot(records)


@pytest.fixture(scope="module")
def page(lot):
    return html_report(lot, title="Panel lot", generated=GENERATED)


@pytest.fixture(scope="module")
def dom(page):
    return _parse(page)


# ---------------------------------------------------------------------------------------------------
# A small DOM from the standard library's parser: enough to find elements by tag, class and id.

_VOID = {"meta", "br", "hr", "img", "link", "input", "col", "area", "base", "source", "wbr"}


class _Node:
    def __init__(self, tag, attrs, parent=None):
        self.tag, self.attrs, self.parent, self.children, self.parts = tag, dict(attrs), parent, [], []

    @property
    def text(self):
        return "".join(part if isinstance(part, str) else part.text for part in self.parts)

    @property
    def classes(self):
        return (self.attrs.get("class") or "").split()

    def iter(self):
        yield self
        for child in self.children:
            yield from child.iter()

    def find_all(self, tag=None, cls=None, **attrs):
        return [node for node in self.iter() if (tag is None or node.tag == tag)
                and (cls is None or cls in node.classes)
                and all(node.attrs.get(name) == value for name, value in attrs.items())]

    def find(self, tag=None, cls=None, **attrs):
        found = self.find_all(tag, cls, **attrs)
        assert found, f"no <{tag} class={cls} {attrs}>"
        return found[0]


class _Builder(HTMLParser):
    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.root = self.current = _Node("#root", {})
        self.unclosed = []

    def handle_starttag(self, tag, attrs):
        node = _Node(tag, attrs, self.current)
        self.current.children.append(node)
        self.current.parts.append(node)
        if tag not in _VOID:
            self.current = node

    def handle_startendtag(self, tag, attrs):
        node = _Node(tag, attrs, self.current)
        self.current.children.append(node)
        self.current.parts.append(node)

    def handle_endtag(self, tag):
        if tag in _VOID:
            return
        assert self.current.tag == tag, f"</{tag}> closes <{self.current.tag}>"
        self.current = self.current.parent

    def handle_data(self, data):
        self.current.parts.append(data)


def _parse(page):
    builder = _Builder()
    builder.feed(page)
    builder.close()
    assert builder.current is builder.root, f"<{builder.current.tag}> left open"
    return builder.root


def _rows(section):
    """The rows of a measurement's table as lists of cell texts, the hole's name carried down its rows."""
    out, hole = [], None
    for row in section.find("table", "holes").find("tbody").find_all("tr"):
        cells = row.find_all("td")
        if cells[0].attrs.get("rowspan") or row.attrs.get("class") == "row-missing":
            hole = cells[0].text
            cells = cells[1:]
        out.append((hole, [cell.text for cell in cells], row, cells))
    return out


def _row(dom, order, hole, name):
    section = dom.find("section", id=f"m-{order}")
    for row_hole, texts, row, cells in _rows(section):
        if row_hole == hole and texts[0] == name:
            return texts, row, cells
    raise AssertionError(f"no row {hole} {name} in m-{order}")


# ---------------------------------------------------------------------------------------------------


def test_the_page_is_well_formed_and_self_contained(page, dom):
    assert page.startswith("<!DOCTYPE html>")
    meta = dom.find("meta", **{"http-equiv": "Content-Security-Policy"})
    assert meta.attrs["content"] == CONTENT_SECURITY_POLICY == (
        "default-src 'none'; style-src 'unsafe-inline'; img-src data:")
    assert not dom.find_all("script") and "<script" not in page.lower()
    assert not dom.find_all("link") and not dom.find_all("img") and not dom.find_all("iframe")
    for node in dom.iter():
        for name, value in node.attrs.items():
            if name in ("src", "href", "xlink:href", "action", "srcset"):
                assert value.startswith(("#", "data:image/png;base64,")), (node.tag, name, value)
            assert not name.startswith("on"), (node.tag, name)
    css = dom.find("style").text
    assert "url(" not in css and "@import" not in css
    assert "@media print" in css and re.search(r"section\.measurement[^{]*\{[^}]*break-before: page", css)


def test_the_header_says_the_inputs_the_version_and_the_decision_rule(dom, records):
    meta = dom.find("header").find("dl")
    said = dict(zip((dt.text for dt in meta.find_all("dt")), (dd.text for dd in meta.find_all("dd"))))
    assert dom.find("h1").text == "Panel lot" and dom.find("title").text == "Panel lot"
    assert said["Generated"] == GENERATED and said["Inputs"] == "shift.jsonl"
    assert said["holecli version"].startswith(holecli.__version__)
    assert f"records by holecli {records[0]['holecli_version']}" in said["holecli version"]
    assert said["Decision rule"] == "simple, coverage factor k = 2"


def test_the_summary_counts_the_lot(dom, lot):
    table = dom.find("section", id="summary").find("table")
    heads = [th.text for th in table.find_all("th")]
    values = dict(zip(heads, (int(td.text) for td in table.find_all("td"))))
    assert values == {"measurements": 4, "parts": 4, "holes": 15, "characteristics": 51, "pass": 2, "fail": 2,
                      "undecided": 0, "unchecked": 0, "error": 0}
    assert values["characteristics"] == len(lot.characteristics)
    for word in ("pass", "fail", "undecided", "unchecked", "error"):
        assert word in table.find("td", word).classes  # coloured by its verdict
    rejected = dom.find("ul", "rejected").find_all("li")
    assert [li.find("a").text for li in rejected] == ["part_002", "part_003"]
    for li in rejected:
        target = li.find("a").attrs["href"]
        assert dom.find("section", id=target[1:]).find("h3").text.startswith(li.find("a").text)
    assert "C1 diameter" in rejected[0].text and "L1 missing" in rejected[1].text


def test_a_table_per_measurement_with_a_row_per_characteristic(dom, lot):
    for measurement in lot.measurements:
        section = dom.find("section", id=f"m-{measurement.order}")
        assert section.find("h3").text.startswith(measurement.label)
        assert measurement.record["file"] in section.find("dl").text
        assert len(_rows(section)) == len(measurement.characteristics)
        for hole, texts, row, cells in _rows(section):
            assert cells[6].text in ("PASS", "FAIL", "UNDECIDED", "MISSING")
            assert cells[6].text.lower() in cells[6].classes  # colour and word


def test_the_oversize_hole_is_marked_fail_with_its_exceedance_and_reason(dom, lot):
    c = next(c for c in lot.series(("C1", "diameter")) if c.decision == "fail")
    assert lot.measurements[c.measurement].label == "part_002"
    texts, row, cells = _row(dom, c.measurement, "C1", "diameter")
    assert texts[1] == "7.0000" and texts[2] == "\u00b10.0500"
    assert texts[3] == f"{c.measured:.4f}" and texts[4] == f"+{c.deviation:.4f}"
    assert texts[5] == f"{c.expanded_uncertainty:.4f}"
    assert texts[6] == "FAIL" and "fail" in cells[6].classes
    assert c.exceedance == pytest.approx(0.0497, abs=5e-4) and texts[7] == f"{c.exceedance:.4f}"
    assert texts[8] == REASON_WORDS["outside"] == "outside the tolerance"
    passed, _, pass_cells = _row(dom, c.measurement, "T1", "diameter")
    assert passed[6] == "PASS" and passed[7] == "" and "pass" in pass_cells[6].classes


def test_the_missing_hole_has_its_row(dom, lot):
    measurement = next(m for m in lot.measurements if m.label == "part_003")
    texts, row, cells = _row(dom, measurement.order, "L1", "presence")
    assert "MISSING" in texts and REASON_WORDS["missing"] in texts
    assert "missing" in row.find("td", "decision").classes


def test_a_zone_characteristic_shows_its_limit(dom, lot):
    c = lot.series(("B1", "position"))[0]
    texts, _, _ = _row(dom, c.measurement, "B1", "position")
    assert texts[1] == "0" and texts[2] == "zone \u2264 0.1000" and texts[3] == f"{c.measured:.4f}"


def test_a_chart_per_characteristic_key(dom, lot):
    sections = dom.find_all("section", "key")
    assert len(sections) == len(lot.keys) == 13
    for section, (hole, name) in zip(sections, lot.keys):
        assert section.find("h3").text.startswith(f"{hole} \u00b7 {name.replace('_', ' ')}")
        charts = section.find_all("figure", "chart")
        assert [sorted(set(f.classes) - {"chart"}) for f in charts] == [["individuals"], ["moving_range"]]
        individuals = charts[0].find("svg")
        assert len(individuals.find("polyline").attrs["points"].split()) == len(lot.series((hole, name)))
        labels = [t.text for t in individuals.find_all("text")]
        assert any(t.startswith("CL ") for t in labels) and any(t.startswith("UCL ") for t in labels)
        assert any("upper tol." in t for t in labels)  # the tolerance: drawn or named off the chart
        assert section.find("svg", **{"aria-label": "histogram"}).find_all("rect", "bar")
        indices = [th.text for th in section.find("table", "capability").find_all("th")[3:]]
        assert indices == ["Cp", "Cpk", "Pp", "Ppk"]
        assert section.find("p", "tur")


def test_the_capability_table_holds_the_indices_and_intervals(dom, lot):
    number = lot.keys.index(("C1", "diameter"))
    section = dom.find("section", id=f"k-{number}")
    values = [c.measured for c in lot.series(("C1", "diameter"))]
    expected = spc.capability(values, 6.95, 7.05, sigma_within=spc.individuals_charts(values)[0].sigma)
    rows = {tr.find("th").text: [td.text for td in tr.find_all("td")]
            for tr in section.find("table", "capability").find_all("tr")[1:]}
    assert rows["Cpk"][0] == f"{expected.cpk:.2f}"
    assert rows["Cp"][1] == f"{expected.cp_interval[0]:.2f} \u2013 {expected.cp_interval[1]:.2f}"
    assert rows["Ppk"][0] == f"{expected.ppk:.2f}"


def test_the_test_uncertainty_ratio_is_said_plainly(dom, lot):
    # T1's 4 mm edge is measured to U = 0.07 mm against +-0.05 mm: the ratio is below 1
    t1 = [c.test_uncertainty_ratio for c in lot.series(("T1", "diameter"))]
    assert max(t1) < 1
    section = dom.find("section", id=f"k-{lot.keys.index(('T1', 'diameter'))}")
    tur = section.find("p", "tur")
    assert "danger" in tur.classes
    assert "the uncertainty is larger than the tolerance: this measurement cannot decide conformance" in tur.text
    c1 = dom.find("section", id=f"k-{lot.keys.index(('C1', 'diameter'))}").find("p", "tur")
    assert "ok" in c1.classes
    # and the summary names it, linked, among the characteristics the measurement decides poorly
    weak = {li.find("a").text: li for li in dom.find("ul", "weak").find_all("li")}
    assert "danger" in weak["T1 diameter"].classes and "cannot decide conformance" in weak["T1 diameter"].text
    assert weak["T1 diameter"].find("a").attrs["href"] == f"#k-{lot.keys.index(('T1', 'diameter'))}"
    assert "C1 diameter" not in weak


@pytest.mark.parametrize("ratio, css, words", [
    (0.99, "danger", "cannot decide conformance"), (1.0, "caution", "caution"), (3.99, "caution", "below 4:1"),
    (4.0, "ok", "4:1 or better"), (None, "note", "not known")])
def test_tur_words_at_their_thresholds(ratio, css, words):
    sentence, got = tur_words(ratio)
    assert got == css and words in sentence


def test_holes_sharing_a_nominal_get_subgroup_charts(dom):
    sections = {s.find("h3").text: s for s in dom.find("section", id="subgroups").find_all("section", "subgroup")}
    # T1 and L1 are both 4.0 +-0.05; every hole has position 0.1; C1 and B1 perpendicularity 0.5 (and
    # C1/B1's diameters are both 7.0 +-0.05)
    assert set(sections) == {"diameter of T1, L1 (nominal 4)", "diameter of C1, B1 (nominal 7)",
                             "position of T1, C1, B1, L1", "perpendicularity of C1, B1"}
    t1_l1 = sections["diameter of T1, L1 (nominal 4)"]
    kinds = [sorted(set(f.classes) - {"chart"}) for f in t1_l1.find_all("figure", "chart")]
    assert kinds == [["xbar"], ["range"]]
    # part_003 has no L1: 3 complete subgroups
    assert len(t1_l1.find("polyline").attrs["points"].split()) == 3
    assert "1 measurement(s) without every one of these holes" in t1_l1.text
    # the x axis is the measurement No.: part_003 (No. 3) is the gap
    xs = [float(point.split(",")[0]) for point in t1_l1.find("polyline").attrs["points"].split()]
    assert xs[1] - xs[0] == pytest.approx((xs[2] - xs[1]) / 2, abs=0.2)  # coordinates to 0.1 px


def test_fit_pictures_per_hole_or_none(lot, dom):
    figures = dom.find_all("figure", "fit")
    assert len(figures) == 15
    assert all(f.find("svg").find("circle", "nominal") for f in figures)
    fail = dom.find("section", id="m-1").find_all("figure", "fit")[1]
    assert fail.find("b").text == "C1" and fail.find("circle", "fail")
    match = re.search(r"\u00d7(\d+)", fail.text)
    assert match and int(match.group(1)) >= 2  # the deviation is magnified, and the page says by how much
    plain = html_report(lot, pictures=False, generated=GENERATED)
    assert not _parse(plain).find_all("figure", "fit") and "Fit pictures" not in plain
    assert len(plain) < len(html_report(lot, generated=GENERATED)) - 15 * 500


def test_a_partial_hole_is_drawn_as_its_arc(records):
    record = copy.deepcopy(records[0])
    record["holes"][0].update(partial=True, arc_deg=200.0)
    dom = _parse(html_report(_lot([record]), generated=GENERATED))
    figure = dom.find_all("figure", "fit")[0]
    assert figure.find("path", "measured") and figure.find("circle", "unseen")
    assert "partial: 200\u00b0 of the edge seen" in figure.text


def test_a_warning_is_said_beside_the_fail_it_may_explain(records):
    record = copy.deepcopy(records[1])  # part_002, C1 fails
    record["holes"][1]["warnings"] = [{"code": "points_inside", "message": "surface points inside (5 points)"},
                                      {"code": "rim_gap", "message": "an arc of 40 degrees empty"}]
    dom = _parse(html_report(_lot([record]), generated=GENERATED))
    texts, row, cells = _row(dom, 0, "C1", "diameter")
    warnings = row.find("td", "warnings").text
    assert "possible chips, burr or lubricant" in warnings and "edge not seen" in warnings
    assert "look at the hole before rejecting it" in warnings
    t1_row = _row(dom, 0, "T1", "diameter")[1]
    assert t1_row.find("td", "warnings").text == ""


def test_the_guarded_rule_shows_undecided_in_amber(guarded_records):
    lot = _lot(guarded_records)
    dom = _parse(html_report(lot, generated=GENERATED))
    assert "guarded, coverage factor k = 2" in dom.find("header").text
    undecided = [c for c in lot.characteristics if c.decision == "undecided"]
    assert undecided  # T1's U exceeds its tolerance: no guarded decision
    c = undecided[0]
    texts, row, cells = _row(dom, c.measurement, c.hole, c.name)
    assert texts[6] == "UNDECIDED" and "undecided" in cells[6].classes
    assert texts[8] == REASON_WORDS[c.reason] and "cannot decide" in texts[8]
    counts = dict(zip((th.text for th in dom.find("table", "summary").find_all("th")),
                      (td.text for td in dom.find("table", "summary").find_all("td"))))
    assert int(counts["undecided"]) == sum(m.verdict == "undecided" for m in lot.measurements) > 0


def test_unchecked_holes_and_error_records(records):
    unchecked = copy.deepcopy(records[0])
    del unchecked["verdict"]
    for hole in unchecked["holes"]:
        hole.pop("conformance", None)
    unchecked["file"] = "scans/plain.ply"
    error = {"file": "scans/broken.ply", "error": "scans/broken.ply: no points in the file"}
    lot = _lot([unchecked, error])
    dom = _parse(html_report(lot, generated=GENERATED))
    rows = _rows(dom.find("section", id="m-0"))
    assert len(rows) == len(unchecked["holes"])
    for (hole, texts, row, cells), record_hole in zip(rows, unchecked["holes"]):
        assert texts[6] == "UNCHECKED" and texts[3] == f"{record_hole['diameter']:.4f}"
        assert texts[8] == "not checked: no tolerances were given for this scan"
    section = dom.find("section", id="m-1")
    assert "ERROR" in section.find("h3").text
    assert "no points in the file" in section.find("p", "error-message").text
    assert [li.find("a").attrs["href"] for li in dom.find("ul", "rejected").find_all("li")] == ["#m-1"]
    assert "no characteristic checked" in dom.find("section", id="trends").text.lower()


def test_fewer_than_two_values_say_so(records):
    dom = _parse(html_report(_lot(records[:1]), generated=GENERATED))
    for section in dom.find_all("section", "key"):
        assert "Not enough measurements for a chart" in section.text
        assert not section.find_all("svg")


def test_an_empty_lot_gives_a_page():
    dom = _parse(html_report(Lot(()), generated=GENERATED))
    assert "No measurements." in dom.find("section", id="measurements").text


def test_run_rule_violations_are_marked_and_listed(records):
    # 20 measurements of part_001's T1 diameter, the 15th 0.04 mm large: beyond the upper control limit
    out = []
    for n in range(20):
        record = copy.deepcopy(records[0])
        record["file"] = f"scans/p{n:02d}.ply"
        deviation = 0.003 * (-1) ** n + (0.04 if n == 14 else 0.0)
        hole = record["holes"][0]
        hole["diameter"] = 4.0 + deviation
        hole["conformance"]["diameter"]["value"] = deviation
        out.append(record)
    lot = _lot(out)
    section = _parse(html_report(lot, generated=GENERATED)).find("section", id="k-0")
    individuals = section.find("figure", "individuals")
    marked = individuals.find_all("circle", "violation")
    assert [c.find("title").text for c in marked] == ["rule 1: beyond the upper control limit"]
    assert "1 run-rule violation(s): rule 1 (a point beyond 3 sigma): 1" in individuals.text
    assert "No. 15 (p14): rule 1, beyond the upper control limit" in individuals.find("ul", "violations").text


def test_every_string_of_a_record_is_escaped(records):
    hostile = '<script>alert("x")</script>\'&"q'
    record = copy.deepcopy(records[1])
    record["file"] = f"scans/{hostile}.ply"
    record["holes"][1]["name"] = hostile
    record["holes"][1]["warnings"] = [{"code": hostile, "message": hostile}]
    record["holes"][1]["conformance"]["diameter"]["reason"] = hostile
    record["holecli_version"] = hostile
    record["verdict"]["decision_rule"] = hostile
    error = {"file": hostile, "error": hostile}
    page = html_report(lot_from_records([{"record": record, "source": f"{hostile}.jsonl:1"},
                                         {"record": error, "source": f"{hostile}:2"}]), title=hostile,
                       generated=hostile)
    assert "<script" not in page.lower() and "</script" not in page.lower()
    dom = _parse(page)
    assert not dom.find_all("script")
    assert dom.find("h1").text == hostile and f"scans/{hostile}.ply" in dom.find("section", id="m-0").find("dl").text
    assert hostile in dom.find("section", id="m-1").find("p", "error-message").text
    escaped = hostile.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
    assert escaped.replace('"', "&quot;").replace("'", "&#x27;") in page
    texts = [node.text for node in dom.iter() if node.tag in ("td", "dd", "li", "b", "p", "h3")]
    assert any(hostile in text for text in texts)


def test_the_header_names_the_inputs_given(lot):
    dom = _parse(html_report(lot, generated=GENERATED, inputs=["shift.jsonl", "late.jsonl"]))
    meta = dom.find("header").find("dl")
    said = dict(zip((dt.text for dt in meta.find_all("dt")), (dd.text for dd in meta.find_all("dd"))))
    assert said["Inputs"] == "shift.jsonl, late.jsonl"


def test_the_scan_around_a_doubtful_hole_is_shown_inline(lot, tmp_path):
    pytest.importorskip("matplotlib", reason="the scan's pictures are drawn with matplotlib (the extra plot)")
    from holecli.cli.report import scan_views

    views = scan_views(lot, 50)  # the oversize C1 of part_002, read again from its scan
    assert set(views) == {(1, 1)}
    gone = {(2, 0): {"unavailable": "the scan <gone>.ply cannot be read now"}}
    page = html_report(lot, generated=GENERATED, scan_views={**views, **gone})
    dom = _parse(page)
    (image,) = dom.find_all("img")
    assert image.attrs["src"].startswith("data:image/png;base64,") and "scan" in image.classes
    assert base64.b64decode(image.attrs["src"].split(",", 1)[1]) == views[(1, 1)]["png"]
    figure = dom.find("section", id="m-1").find("figure", "scan")
    assert figure.find("b").text == "C1" and figure.find("img") is image
    assert "the scan <gone>.ply cannot be read now" in dom.find("section", id="m-2").find("figure", "scan").text
    assert "Scan pictures:" in dom.find("section", id="m-1").text
    no_fits = _parse(html_report(lot, generated=GENERATED, pictures=False, scan_views=views))
    assert len(no_fits.find_all("figure", "fit")) == 1  # the scan's picture alone


def test_a_hole_the_spec_does_not_name_is_unchecked_beside_the_checked(records):
    record = copy.deepcopy(records[0])
    extra = copy.deepcopy(record["holes"][0])
    for key in ("name", "conformance", "in_tolerance", "failed_checks", "undecided_checks"):
        extra.pop(key, None)
    extra.update(index=len(record["holes"]), diameter=2.5)
    record["holes"].append(extra)
    dom = _parse(html_report(_lot([record]), generated=GENERATED))
    hole, texts, row, cells = _rows(dom.find("section", id="m-0"))[-1]
    assert hole == f"#{extra['index']}" and texts[3] == "2.5000" and texts[6] == "UNCHECKED"
    assert texts[8] == "not checked: no nominal hole of the spec matches it"


def test_an_unsymmetric_band_shows_both_limits(records):
    record = copy.deepcopy(records[0])
    record["holes"][0]["conformance"]["diameter"].update(lower=0.0, upper=0.036)  # a drawing's +0.036/-0
    dom = _parse(html_report(_lot([record]), generated=GENERATED))
    texts, _, _ = _row(dom, 0, "T1", "diameter")
    assert texts[2] == "+0.00000 / +0.03600"  # to about a thousandth of the zone


def test_a_hole_part_that_is_not_what_a_record_holds_is_drawn_as_absent(records):
    record = copy.deepcopy(records[0])
    hole = record["holes"][0]
    hole.update(position_deviation=3.0, arc_deg="x", partial=True, diameter_deviation=None)
    dom = _parse(html_report(_lot([record]), generated=GENERATED))
    figures = dom.find_all("figure", "fit")
    assert len(figures) == len(record["holes"]) and "partial" not in figures[0].text
    # (a hole's warnings that are not a list are refused before: holecli.quality.lot, test_lot.py)


def test_a_part_rejected_twice_is_one_part_rejected(records):
    twice = [*records, *records]  # the shift's records read twice (two logs holding them)
    dom = _parse(html_report(_lot(twice), generated=GENERATED))
    heading = next(h for h in dom.find_all("h3") if h.text.startswith("Parts rejected"))
    assert heading.text == "Parts rejected (2)"  # part_002 and part_003, each once
