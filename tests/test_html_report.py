"""``OUT/report.html``: one self-contained page per study.  Its structure is read with the
standard library's HTML parser; where the machine has Debian's Chromium and ChromeDriver (``.ci/run``
installs them), a real headless browser opens it and every picture must load."""

from __future__ import annotations

import base64
import html
import io
import shutil
from html.parser import HTMLParser
from pathlib import Path

import pytest
from PIL import Image

from workflows.html_report import FIGURE_CAPTIONS, REPORT_FILE, _result_figures, write_html_report
from workflows.output.figures import pyplot, save_figure
from workflows.study_types import study_type

REPO = Path(__file__).resolve().parents[1]
CHROMIUM, CHROMEDRIVER = shutil.which("chromium"), shutil.which("chromedriver")


class Page(HTMLParser):
    """What a report page holds: its sections, images, links, headlines, preformatted blocks and
    table rows (as lists of cell texts)."""

    VOID = {"img", "meta", "link", "br", "hr", "input"}

    def __init__(self, text: str):
        super().__init__(convert_charrefs=True)
        self.sections, self.images, self.links, self.headlines, self.pres, self.rows = [], [], [], [], [], []
        self._open: list[str] = []  # the open elements, a headline paragraph as "headline"
        self.feed(text)

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if tag == "section":
            self.sections.append(attrs.get("id"))
        elif tag == "img":
            self.images.append(attrs)
        elif tag == "tr":
            self.rows.append([])
        elif tag in ("td", "th"):
            self.rows[-1].append("")
        elif tag == "pre":
            self.pres.append("")
        if tag in ("a", "link", "script", "iframe", "object", "embed"):
            self.links.append((tag, attrs.get("href") or attrs.get("src")))
        if tag == "p" and attrs.get("class") == "headline":
            self.headlines.append("")
            tag = "headline"
        if tag not in self.VOID:
            self._open.append(tag)

    def handle_endtag(self, tag):
        if tag not in self.VOID:
            self._open.pop()

    def handle_data(self, data):
        if "pre" in self._open:
            self.pres[-1] += data
        if "headline" in self._open:
            self.headlines[-1] += data
        if ("td" in self._open or "th" in self._open) and "table" in self._open:
            self.rows[-1][-1] += data


def _pictures(page: Page) -> dict[str, Image.Image]:
    """Each embedded picture by its alt text; every one a PNG given as a data: address."""
    pictures = {}
    for image in page.images:
        prefix = "data:image/png;base64,"
        assert image["src"].startswith(prefix), image["src"][:40]
        picture = Image.open(io.BytesIO(base64.b64decode(image["src"][len(prefix):], validate=True)))
        picture.load()
        assert picture.format == "PNG" and min(picture.size) > 100
        pictures[image["alt"]] = picture
    return pictures


def _write(run) -> tuple[Path, Page]:
    study, out, outcome = run
    path = write_html_report(study_type(study, out), outcome, REPO / "studies" / f"{study.name}.toml")
    assert path == out / REPORT_FILE and not (out / f"{REPORT_FILE}.tmp").exists()
    return path, Page(path.read_text(encoding="utf-8"))


def test_the_fos_report_holds_the_verdict_inputs_every_figure_and_the_study_text(quickstart_run):
    """The quickstart's page: the FOS line as its headline and the printed report; the section drawing,
    the materials as read (c = 10 kPa in Pa); every figure the study drew, and nothing else; the study
    text as read; no address outside the page."""
    study, out, outcome = quickstart_run
    _, page = _write(quickstart_run)
    assert page.sections == ["result", "inputs", "figures", "study-file"]
    assert page.headlines == [outcome.verdict]
    printed = page.pres[0]
    assert outcome.verdict in printed and "slip surface (SRF" in printed and "Spencer" in printed
    pictures = _pictures(page)
    assert set(pictures) == {"section"} | {path.name for path in outcome.figures}
    assert {"srf_curve.png", "slip_surface.png"} <= set(pictures)
    assert ["cohesion_pa (Pa)", "10000"] in page.rows and ["kind", "drucker_prager"] in page.rows
    assert html.unescape(page.pres[-1]) == study.source_text
    assert all(tag == "a" and href.startswith("#") for tag, href in page.links), page.links


def test_a_sweep_report_shows_its_table_and_design_charts(strength_sweep):
    study, out, outcome = strength_sweep
    _, page = _write(strength_sweep)
    assert page.headlines == []  # a sweep has no one verdict: its table is the result
    assert "cohesion_pa  friction_deg" in page.pres[0] and page.pres[0].count("found") == 9
    assert {"section", "fos_map.png", "fos_cohesion_pa.png", "fos_friction_deg.png"} == set(_pictures(page))


def test_a_probabilistic_report_shows_pf_its_variables_and_the_slip_envelope(tmp_path):
    """8 realisations of a lognormal cohesion on the quickstart, judged at F = 1.3 (2 fail): pf as the
    headline, the random variable's table among the inputs, pf's convergence and the slip envelope."""
    from workflows.cases import RunOptions
    from workflows.study import parse_study
    from workflows.study_types import run_study

    text = (REPO / "studies" / "quickstart.toml").read_text() + (
        '\n[probabilistic]\nrealisations = 8\nseed = 3\nfactor = 1.3\n[[probabilistic.variables]]\n'
        'path = "materials.soil.cohesion_pa"\ndistribution = "lognormal"\ncov = 0.3\n')
    study = parse_study(text)
    outcome = run_study(study, tmp_path, RunOptions(workers=2))
    _, page = _write((study, tmp_path, outcome))
    assert len(page.headlines) == 1 and page.headlines[0].startswith("pf = 0.25, 95% interval")
    assert ["path", "materials.soil.cohesion_pa"] in page.rows and ["distribution", "lognormal"] in page.rows
    assert {"section", "pf_convergence.png", "slip_envelope.png"} <= set(_pictures(page))


def test_only_our_pictures_are_shown_in_the_order_of_the_captions(tmp_path):
    """A user's PNG in the output folder is not ours and stays out of the page; ours come in the
    captions' order, a stage's final state (any other name) last."""
    plt = pyplot()
    for name in ("fields_srf_1.2000.png", "slip_surface.png", "runout.png", "srf_curve.png"):
        fig = plt.figure(figsize=(2, 2))
        save_figure(fig, tmp_path / name)
        plt.close(fig)
    Image.new("RGB", (200, 200)).save(tmp_path / "my_photo.png")
    shown = [(path.name, caption) for path, caption in _result_figures(tmp_path)]
    assert [name for name, _ in shown] == ["srf_curve.png", "slip_surface.png", "fields_srf_1.2000.png", "runout.png"]
    assert shown[-1][1] == "The final state of the stage 'runout'."


def test_every_figure_a_study_draws_has_a_caption():
    from workflows.fos.figures import FIGURE_NAMES as FOS_FIGURES
    from workflows.probabilistic.design_points import FIGURES as DESIGN_POINT_FIGURES
    from workflows.probabilistic.figures import FIGURE_NAMES as PROBABILISTIC_FIGURES
    from workflows.sweep.stale import SWEEP_FIGURE_NAMES

    patterns = [pattern for pattern, _ in FIGURE_CAPTIONS]
    for name in (*FOS_FIGURES, *PROBABILISTIC_FIGURES, *DESIGN_POINT_FIGURES, *SWEEP_FIGURE_NAMES, "convergence.png", "pf.png",
                 "seepage.png"):
        assert name in patterns, name


@pytest.mark.skipif(not (CHROMIUM and CHROMEDRIVER), reason="no headless browser here: the test needs Debian's "
                    "chromium and chromium-driver (apt-get install chromium chromium-driver; .ci/run installs them)")
def test_the_report_renders_in_a_headless_browser_and_every_picture_loads(quickstart_run, tmp_path):
    """Chromium opens the page from disk with the network off: it loads, every picture decodes at
    its full size, and nothing is wider than a 1200 px window.  The screenshot is left in tmp_path."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    path, page = _write(quickstart_run)
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for flag in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync",
                 "--window-size=1200,2000", f"--user-data-dir={tmp_path / 'profile'}"):
        options.add_argument(flag)
    driver = webdriver.Chrome(options=options, service=Service(CHROMEDRIVER))
    try:
        driver.get(path.as_uri())
        assert driver.execute_script("return document.readyState") == "complete"
        assert driver.title == f"{quickstart_run[0].name}: spfem-fos report"
        images = driver.execute_script(
            "return Array.from(document.images).map(i => [i.alt, i.complete, i.naturalWidth, i.width])")
        assert len(images) == len(page.images) >= 4
        for alt, complete, natural_width, width in images:
            assert complete and natural_width > 300 and width > 300, (alt, complete, natural_width, width)
        assert driver.execute_script("return document.documentElement.scrollWidth <= window.innerWidth")
        driver.save_screenshot(str(tmp_path / "report.png"))
    finally:
        driver.quit()
