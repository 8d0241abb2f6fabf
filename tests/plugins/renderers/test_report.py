"""`odsuite report`: one self-contained HTML page whose numbers are compare's, diagnose's and
history's, with embedded figures and movie, that renders in headless Chromium without errors.

The project: the simulated thesis rig with a hidden stiffer z suspension (scale 1.6), three
experiments of 4096 samples, a diagnosis at revision 0 and the stiffness added as revision 1.
Building it and the page takes tens of seconds on a shared machine: those tests are marked slow
(`make report-check` runs them with the Chromium check).
"""

from __future__ import annotations

import base64
import io
import json
import re
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

from odsuite.domain.errors import ConfigError

CHROMIUM = Path("/usr/bin/chromium")


class _Page(HTMLParser):
    """Collects the page's images, links, scripts, section ids and table cells by table id."""

    def __init__(self) -> None:
        super().__init__()
        self.images: list[str] = []
        self.urls: list[str] = []
        self.scripts = 0
        self.script_sources: list[str] = []
        self.ids: list[str] = []
        self.tables: dict[str, list[list[str]]] = {}
        self._table: str | None = None
        self._cell: list[str] | None = None
        self.text: dict[str, str] = {}
        self._span: str | None = None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if "id" in a:
            self.ids.append(a["id"])
        if tag == "img":
            self.images.append(a.get("src", ""))
        for k in ("href", "src"):
            if k in a and tag != "img":
                self.urls.append(a[k])
        if tag == "script":
            self.scripts += 1
            if "src" in a:
                self.script_sources.append(a["src"])
        if tag == "table" and "id" in a:
            self._table = a["id"]
            self.tables[self._table] = []
        if self._table and tag == "tr":
            self.tables[self._table].append([])
        if self._table and tag in ("td", "th"):
            self._cell = []
        if tag in ("span", "b") and "id" in a:
            self._span = a["id"]
            self.text[self._span] = ""

    def handle_endtag(self, tag):
        if tag == "table":
            self._table = None
        if self._table and tag in ("td", "th") and self._cell is not None:
            self.tables[self._table][-1].append("".join(self._cell).strip())
            self._cell = None
        if tag in ("span", "b"):
            self._span = None

    def handle_data(self, data):
        if self._cell is not None:
            self._cell.append(data)
        if self._span is not None:
            self.text[self._span] += data


def parse(path: Path) -> _Page:
    page = _Page()
    page.feed(path.read_text(encoding="utf-8"))
    return page


@pytest.fixture(scope="module")
def story(tmp_path_factory):
    """The project, the diagnosis made at revision 0 and the report built with them."""
    from odsuite.diagnosis.add_effect import add_effect
    from odsuite.diagnosis.diagnose import diagnose
    from odsuite.store.project import open_project
    from odsuite_plugins.renderers.report import build_report
    from tests.core.hidden_effects import make_project

    tmp = tmp_path_factory.mktemp("report")
    path = make_project(tmp / "p.h5", [("stiffness", {"scale_z": 1.6})], n_samples=4096,
                        scenarios=("T1", "T3", "T5"))
    with open_project(path, "a") as p:
        diag = diagnose(p, effects=["stiffness", "damping"]).as_dict()
        added = add_effect(p, "stiffness")
    (tmp / "diagnosis.json").write_text(json.dumps(diag))
    result = build_report(path, tmp / "report.html", diagnosis=tmp / "diagnosis.json")
    return path, diag, added, result


@pytest.mark.slow
def test_report_numbers_are_compares(story):
    from odsuite.analysis.comparison import compare
    from odsuite.analysis.history import history
    from odsuite.store.project import open_project
    from odsuite_plugins.renderers.report import SECTIONS

    path, diag, added, result = story
    with open_project(path) as p:
        cmp = compare(p).as_dict()
        hist = history(p)
    page = parse(result.path)
    assert all(s in page.ids for s in SECTIONS)
    assert result.error == cmp["error"] and cmp["revision"] == added["revision"] == 1
    # the hidden stiffness explains nearly all of the rigid model's error
    assert cmp["error"] < 0.05 and added["previous_error"] > 0.5
    assert page.text["error"] == f"{cmp['error']:.4f}"
    assert page.text["noise-floor"] == f"{cmp['noise_floor_error']:.4f}"
    rows = page.tables["channel-errors"]  # a row per channel, a column per experiment, then all
    experiments = rows[0][1:-1]
    assert experiments == list(cmp["experiments"]) and rows[0][-1] == "all"
    assert [r[0] for r in rows[1:]] == [*cmp["channels"], "all"]
    # a channel clipped at its converter's limits is left out of that experiment's comparison (compare
    # notes it): its cell is a dash; here the stiffer z suspension clips T3's x1 and x3
    clipped = {m.groups() for n in cmp["notes"]
               for m in [re.search(r"experiment '(\w+)': channel \d+ \((\w+)\) is clipped at its converter", n)] if m}
    left_out = {(e, ch) for e in experiments for ch in cmp["channels"] if ch not in cmp["experiments"][e]["channels"]}
    assert left_out == clipped
    for row in rows[1:]:
        if row[0] == "all":
            assert row[1:] == [f"{cmp['experiments'][e]['error']:.4f}" for e in experiments] + [f"{cmp['error']:.4f}"]
        else:
            assert row[1:] == ["–" if (e, row[0]) in clipped else f"{cmp['experiments'][e]['channels'][row[0]]:.4f}"
                               for e in experiments] + [f"{cmp['channels'][row[0]]:.4f}"]
    assert [r[0] for r in page.tables["experiments"][1:]] == ["T1", "T3", "T5"]
    worst = page.tables["worst"][1:]
    assert [(r[0], r[1], r[2]) for r in worst] == [(w["kind"], w["name"], f"{w['error']:.4f}") for w in cmp["worst"]]
    assert [r[3] for r in page.tables["history"][1:]] == [f"{r['error']:.4f}" for r in hist["revisions"]]
    assert hist["noise_floor_error"] == pytest.approx(cmp["noise_floor_error"], rel=1e-12)
    # the test record: the version that wrote the page, and every channel's serial and calibration
    from odsuite.domain.version import __version__

    meta = dict((r[0], r[1]) for r in page.tables["metadata"][1:])
    assert meta["software"].startswith(f"odsuite {__version__} ")
    with open_project(path) as p:
        si = p.experiment("T1").systeminfo
    chans = page.tables["channels"][1:]
    assert [r[3] for r in chans] == [c.serial or "–" for c in si.channels]
    assert [float(r[4].split()[0]) for r in chans] == pytest.approx([c.sensitivity for c in si.channels], rel=1e-5)
    # the ranking is the diagnosis's, and the stiffness (the hidden effect) leads it
    cands = page.tables["candidates"][1:]
    assert [r[1] for r in cands] == [c["effect"] for c in diag["candidates"]]
    assert cands[0][1] == "stiffness" and cands[0][2] == "yes"
    assert any("revision 0" in n and "current one is 1" in n for n in result.notes)


@pytest.mark.slow
def test_report_is_self_contained(story, tmp_path):
    from PIL import Image

    from odsuite.analysis.comparison import compare
    from odsuite.store.project import open_project

    path, *_, result = story
    page = parse(result.path)
    assert 0 < result.size_bytes < 4 * 2**20  # a page a lab mails around
    # the two 3-D views' scripts (the recorded motion and the measured mode shapes, each its data
    # and its code) are inline; nothing is fetched: links are in-page, sources data URIs
    assert page.scripts == 4 and page.script_sources == []
    assert all(u.startswith(("#", "data:video/mp4;base64,")) for u in page.urls), [u[:40] for u in page.urls]
    kinds = []
    for src in page.images:
        m = re.fullmatch(r"data:image/(png|gif);base64,(.+)", src, flags=re.DOTALL)
        assert m, src[:60]
        with Image.open(io.BytesIO(base64.b64decode(m.group(2)))) as im:
            kinds.append((im.format, getattr(im, "n_frames", 1), im.size))
    # three experiments x (coordinates + channels), the channels around the hit in the experiment of
    # the strongest band above its floor (which sets the first views' window), two heat maps, residual spectra,
    # history, movie, each hammer record's FRF and stabilisation diagram and the MAC of each record
    # with measured modes
    with open_project(path) as p:
        records = compare(p).modal_records
    hit_views = 1 if "The model fails most in" in result.path.read_text() else 0
    diagrams = sum(r.modes is not None and r.modes.diagram is not None for r in records)
    assert sum(k[0] == "PNG" for k in kinds) == (3 * 2 + hit_views + 2 + 1 + 1 + len(records) + diagrams
                                                 + sum(r.mac is not None for r in records))
    # the movie is the <video>'s MP4 alone: a GIF copy inside <video> is shown by no browser that plays video
    assert not any(k[0] == "GIF" for k in kinds)
    import imageio_ffmpeg

    movie = [u for u in page.urls if u.startswith("data:video/mp4;base64,")]
    assert len(movie) == 1
    mp4 = tmp_path / "movie.mp4"
    mp4.write_bytes(base64.b64decode(movie[0].split(",", 1)[1]))
    reader = imageio_ffmpeg.read_frames(str(mp4))
    assert next(reader)["size"] == (640, 360) and sum(1 for _ in reader) > 30
    assert result.movie_experiment in ("T1", "T3", "T5")


def test_model_coordinates_are_compares_to_the_bit(tmp_path):
    """The motion render --model and the report draw is solved on compare's one BLAS thread: on
    two threads the 4096-sample solves summed in another order (1e-10 relative from compare's)."""
    from odsuite.analysis.comparison import COORDINATE_NAMES, compare, nrmse
    from odsuite.analysis.prediction import experiment_coordinates
    from odsuite.store.project import open_project
    from tests.core.hidden_effects import make_project

    path = make_project(tmp_path / "p.h5", [("stiffness", {"scale_z": 1.6})], n_samples=4096, scenarios=("T1",))
    with open_project(path) as p:
        want = compare(p, resonances=False, figures=False).as_dict()["coordinates"]["T1"]["platform"]
        gm, gp = experiment_coordinates(p, "T1")["platform"]
    assert [float(nrmse(gm[:, i], gp[:, i])) for i in range(6)] == [want[c] for c in COORDINATE_NAMES]


@pytest.mark.slow
def test_model_coordinates_match_compare(story):
    """The on-the-fly model motion (render --model, the movie) gives compare's per-coordinate errors."""
    from odsuite.analysis.comparison import COORDINATE_NAMES, compare, nrmse
    from odsuite.analysis.prediction import experiment_coordinates
    from odsuite.store.project import open_project

    path, *_ = story
    with open_project(path) as p:
        cmp = compare(p).as_dict()
        for name in p.experiment_names():
            pairs = experiment_coordinates(p, name)
            assert set(pairs) == {"platform"}
            gm, gp = pairs["platform"]
            assert gm.shape == gp.shape == (4096, 6)
            got = [float(nrmse(gm[:, i], gp[:, i])) for i in range(6)]
            want = [cmp["coordinates"][name]["platform"][c] for c in COORDINATE_NAMES]
            assert got == pytest.approx(want, rel=1e-12)
        # the fitted model follows the measured motion along the force (x for T5, z for T1)
        gm, gp = experiment_coordinates(p, "T5")["platform"]
        assert nrmse(gm[:, 0], gp[:, 0]) < 0.1
        gm, gp = experiment_coordinates(p, "T1")["platform"]
        assert nrmse(gm[:, 2], gp[:, 2]) < 0.1


@pytest.mark.slow
def test_cli_report_without_diagnosis_and_movie(story, tmp_path, capsys):
    from odsuite.cli import main
    from odsuite.analysis.comparison import compare
    from odsuite.store.project import open_project

    path, *_ = story
    out = tmp_path / "r.html"
    assert main(["report", str(path), "-o", str(out), "--no-diagnose", "--no-movie"]) == 0
    stdout, err = capsys.readouterr()
    with open_project(path) as p:
        error = compare(p).error
    assert f"error {error:.4f}" in stdout
    assert "diagnosis skipped" in err and "movie skipped" in err
    page = parse(out)
    assert "candidates" not in page.tables and not any(s.startswith("data:image/gif") for s in page.images)


@pytest.mark.render
@pytest.mark.slow
def test_report_renders_in_chromium(story, tmp_path):
    if not CHROMIUM.exists():
        pytest.skip(f"{CHROMIUM} not found: `apt-get update && apt-get install -y chromium` to check the page")
    from PIL import Image

    *_, result = story
    shot = tmp_path / "shot.png"
    run = subprocess.run(
        [str(CHROMIUM), "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         f"--user-data-dir={tmp_path / 'profile'}", "--enable-logging=stderr", "--v=0",
         # the page's first 5000 px hold the summary and each record's FRF and MAC: the overlays follow
         f"--screenshot={shot}", "--window-size=1280,8000", result.path.resolve().as_uri()],
        capture_output=True, text=True, timeout=180, check=False)
    assert run.returncode == 0, run.stderr[-2000:]
    console = [ln for ln in run.stderr.splitlines() if ":CONSOLE" in ln or "Uncaught" in ln]
    assert not console, console
    with Image.open(shot) as im:
        a = np.asarray(im.convert("RGB")).astype(int)
    assert a.shape == (8000, 1280, 3)
    # the overlays are on screen: the measured traces' blue (tab:blue 31,119,180) and the model's black
    blue = (np.abs(a - [31, 119, 180]).sum(axis=2) < 60).sum()
    black = (a.sum(axis=2) < 60).sum()
    assert blue > 2000 and black > 20000, (blue, black)


def test_bad_input_is_one_line(tmp_path):
    from odsuite.store.project import create_project
    from odsuite_plugins.renderers.report import build_report, load_diagnosis

    bad = tmp_path / "d.json"
    bad.write_text("{not json")
    with pytest.raises(ConfigError, match=r"d\.json: not a JSON document"):
        load_diagnosis(bad)
    bad.write_text(json.dumps({"baseline_error": 0.1}))
    with pytest.raises(ConfigError, match=r"d\.json: field 'candidates': expected a list of candidate tables .*, got None"):
        load_diagnosis(bad)
    with pytest.raises(ConfigError, match=r"field 'candidates\[1\]\.effect': expected an effect name, got None"):
        load_diagnosis({"candidates": [{"effect": "stiffness"}, {"name": 3}]})
    with pytest.raises(ConfigError, match="missing.json: cannot read"):
        load_diagnosis(tmp_path / "missing.json")
    with pytest.raises(ConfigError, match=r"r\.pdf: the report is an HTML page"):
        build_report(tmp_path / "p.h5", tmp_path / "r.pdf")
    create_project(tmp_path / "none.h5", rig=None).close()
    with pytest.raises(ConfigError, match="no rig"):
        build_report(tmp_path / "none.h5", tmp_path / "r.html", run_diagnosis=False, movie=False)
    assert not (tmp_path / "r.html").exists()


def test_modal_table_of_the_rigid_model_is_compares(story):
    """The thesis rig's rigid-body model: the report tables compare's measured-against-model modes,
    with MAC from the nine accelerometers' shapes."""
    from odsuite.analysis.comparison import compare
    from odsuite.store.project import open_project

    path, _, _, result = story
    with open_project(path) as p:
        rows = compare(p).as_dict()["modal"]
    table = parse(result.path).tables["modal-table"][1:]
    assert [r[0] for r in table] == [r["experiment"] for r in rows] and rows
    assert [r[1] for r in table] == [f"{r['measured_hz']:.2f}" for r in rows]
    paired = [r for r in rows if r["model_hz"] is not None]
    assert paired and all(r["mac"] is not None and 0 <= r["mac"] <= 1 + 1e-12 for r in paired)
    # after the fit the model is the simulator's truth: its modes are the measured ones
    assert all(abs(r["model_hz"] / r["measured_hz"] - 1) < 0.02 for r in paired if r["mac"] > 0.9)


#: the width of a printed A4/Letter text column (inches) and the smallest type readable on it (pt)
PRINT_WIDTH_IN = 6.5
SMALLEST_TYPE_PT = 8.0


def _visible_texts(fig):
    from matplotlib.text import Text

    return [t for t in fig.findobj(Text) if t.get_visible() and t.get_text().strip()]


@pytest.mark.slow
def test_report_draws_each_records_frf_and_mac(story, tmp_path, monkeypatch):
    """Per hammer record: the driving point's FRF on log-frequency axes (magnitude log-log, phase,
    coherence) with its unit, and the MAC matrix of measured against model modes whose values are
    compare's MAC numbers; at print width with type of 8 pt or more."""
    from odsuite_plugins.renderers import modal_figures
    from odsuite.analysis.comparison import compare
    from odsuite.store.project import open_project
    from odsuite_plugins.renderers.report import build_report

    path, *_ = story
    drawn: dict[str, list] = {"frf": [], "mac": []}
    for kind, name in (("frf", "frf_figure"), ("mac", "mac_figure")):
        original = getattr(modal_figures, name)

        def spy(*args, _original=original, _kind=kind, **kwargs):
            fig = _original(*args, **kwargs)
            drawn[_kind].append((args, kwargs, fig))
            return fig

        monkeypatch.setattr(modal_figures, name, spy)
    result = build_report(path, tmp_path / "r.html", run_diagnosis=False, movie=False)
    with open_project(path) as p:
        cmp = compare(p)
        rig = p.rig
        # the driving point, found independently: of the sensors at the point nearest each record's
        # force point (a corner's three axes) among those within 60 degrees of the blow's line (any,
        # when none is), the one along the hammer's direction
        nearest = {}
        for name in p.experiment_names():
            exc = p.experiment(name).excitation
            sensors = [s for s in rig.sensors if s.position is not None]
            sensors = [s for s in sensors if abs(np.dot(s.axis, exc.direction)) >= 0.5] or sensors
            d = min(np.linalg.norm(s.position - exc.point) for s in sensors)
            corner = [s for s in sensors if np.linalg.norm(s.position - exc.point) <= d + 1e-3]
            nearest[name] = max(corner, key=lambda s: abs(np.dot(s.axis, exc.direction))).name
    records = cmp.modal_records
    with_mac = [r for r in records if r.mac is not None]  # records with measured modes and shapes
    assert records and len(drawn["frf"]) == len(records) and len(drawn["mac"]) == len(with_mac) > 0
    page = parse(result.path)
    frf_alts = re.findall(r'alt="([^"]*FRF of the driving point[^"]*)"', result.path.read_text())
    assert len(frf_alts) == len(records)
    for rec, alt in zip(records, frf_alts):
        assert alt.startswith(f"{rec.experiment}: FRF of the driving point {nearest[rec.experiment]} ")
    assert len(page.images) >= 2 * len(records)

    for (args, kwargs, fig), rec in zip(drawn["frf"], records):
        assert kwargs["outputs"] == [nearest[rec.experiment]]
        mag, phase, coh = fig.axes
        assert [ax.get_xscale() for ax in (mag, phase, coh)] == ["log"] * 3 and mag.get_yscale() == "log"
        assert mag.get_ylabel() == "|H| [(m/s²)/N]" and coh.get_xlabel() == "frequency [Hz]"
        assert phase.get_ylabel() == "phase [°]"
        # the magnitude drawn is |H| of that channel, the FRF compare identified the modes from,
        # with each record's straight line (offset, drift) removed, from 3 cycles per record up
        k = rec.frf.output_names.index(nearest[rec.experiment])
        f = rec.frf.frequency
        lo, hi = rec.band_hz or (0.0, np.inf)
        pos = (f >= f[3]) & (f >= lo) & (f <= hi)  # the fit band, not the noise above it
        assert np.allclose(mag.lines[0].get_ydata(), np.abs(rec.frf.H[k, pos] - rec.frf.trend[k, pos]))
        assert "straight line (offset, drift) removed" in mag.get_title().replace("\n", " ")
        assert lo <= mag.get_xlim()[0] and mag.get_xlim()[1] <= hi
        assert fig.get_figwidth() <= PRINT_WIDTH_IN
        assert min(t.get_fontsize() for t in _visible_texts(fig)) >= SMALLEST_TYPE_PT

    rows = cmp.as_dict()["modal"]
    checked = 0
    for (args, kwargs, fig), rec in zip(drawn["mac"], with_mac):
        m = np.asarray(args[0])
        assert m.shape == (rec.measured_hz.size, rec.model_hz.size)
        assert np.all((m >= 0) & (m <= 1 + 1e-12))
        for r in (r for r in rows if r["experiment"] == rec.experiment and r["mac"] is not None):
            i = int(np.argmin(np.abs(rec.measured_hz - r["measured_hz"])))
            j = int(np.argmin(np.abs(rec.model_hz - r["model_hz"])))
            assert m[i, j] == pytest.approx(r["mac"], abs=1e-12)
            # and the number written in that cell is that value
            assert f"{r['mac']:.2f}" in [t.get_text() for t in fig.axes[0].texts]
            checked += 1
        assert fig.get_figwidth() <= PRINT_WIDTH_IN
        assert min(t.get_fontsize() for t in _visible_texts(fig)) >= SMALLEST_TYPE_PT
    assert checked == sum(r["mac"] is not None for r in rows) > 0


@pytest.mark.slow
def test_frf_channel_that_no_record_has_is_one_line(story, tmp_path):
    from odsuite_plugins.renderers.report import build_report

    path, *_ = story
    with pytest.raises(ConfigError, match=r"--frf-channel 'nope': experiment 'T1' has no such response channel"):
        build_report(path, tmp_path / "r.html", run_diagnosis=False, movie=False, frf_channels=["nope"])
    assert not (tmp_path / "r.html").exists()


def test_a_table_without_rows_is_one_sentence():
    """No table prints its header with no rows: the sentence saying why stands in its place."""
    from odsuite_plugins.renderers.report import _table

    none = _table(["frequency [Hz]"], [], id="peaks", caption="peaks", empty="No peak stands above the floor.")
    assert "<table" not in none and "No peak stands above the floor." in none
    assert "<table" not in _table(["a"], [], caption="peaks") and "peaks: none." in _table(["a"], [], caption="peaks")
    assert _table(["a"], [[1]], id="t").count("<tr>") == 2


@pytest.mark.slow
def test_report_has_no_empty_table_and_draws_the_models_frf(story):
    """Every table of the page has a row under its header; each FRF figure has the model's line."""
    *_, result = story
    page = parse(result.path)
    assert page.tables and all(len(rows) >= 2 for rows in page.tables.values())
    text = result.path.read_text()
    assert text.count("black dashed: the model&#x27;s FRF") == text.count("FRF of the driving point") > 0
    assert text.count(": poles of every model order in the fit band") > 0  # the stabilisation diagrams


def test_diagnosis_not_finite_reads_as_null(tmp_path):
    """NaN and Infinity (json.dumps of an API diagnosis) read as null, as `diagnose --json` writes them."""
    from odsuite_plugins.renderers.report import load_diagnosis

    path = tmp_path / "d.json"
    path.write_text('{"candidates": [{"effect": "stiffness", "error": NaN, "error_before": -Infinity, "x": 0.5}]}')
    assert load_diagnosis(path)["candidates"] == [{"effect": "stiffness", "error": None, "error_before": None, "x": 0.5}]


def test_figures_are_embedded_as_256_colour_pngs_that_keep_the_figure(tmp_path):
    """A report figure (dense traces on log axes, a colour bar) as the page embeds it: at most 256
    colours, at most half the bytes of matplotlib's PNG, every white pixel still white and the
    others moved by less than 0.5/255 on average."""
    from matplotlib.figure import Figure
    from PIL import Image

    from odsuite_plugins.renderers.report import FIGURE_DPI, _palette_png

    rng = np.random.default_rng(7)
    f = np.linspace(1, 1000, 4000)
    fig = Figure(figsize=(8.4, 5.4), layout="constrained")
    ax, ax2 = fig.subplots(1, 2)
    for k in range(3):
        ax.loglog(f, (1 + k) / np.abs(1 - (f / (30 * (k + 1))) ** 2 + 0.05j) * (1 + 0.3 * rng.random(f.size)))
    ax.grid(True, which="both", lw=0.3)
    im = ax2.imshow(rng.random((12, 6)), cmap="magma_r")
    fig.colorbar(im, ax=ax2, label="NRMSE [–]")
    path = tmp_path / "fig.png"
    fig.savefig(path, dpi=FIGURE_DPI)
    before = path.stat().st_size
    with Image.open(path) as a:
        original = np.asarray(a.convert("RGB")).astype(int)
    _palette_png(path)
    with Image.open(path) as b:
        assert b.mode == "P" and len(b.getcolors(256)) <= 256
        shown = np.asarray(b.convert("RGB")).astype(int)
    assert path.stat().st_size <= before / 2, (path.stat().st_size, before)
    white = (original == 255).all(axis=2)
    assert white.sum() > 0.3 * white.size and (shown[white] == 255).all()
    assert np.abs(shown - original).mean() < 0.5


def test_a_figure_of_many_coloured_lines_keeps_each_lines_colour(tmp_path):
    """40 lines around the hue wheel (as a stabilisation diagram or a many-channel overlay draws
    them) have more colours with their antialiasing than a palette holds: each line's own colour
    is still within 8/255 on the page and no two lines share one."""
    from matplotlib import colormaps
    from matplotlib.figure import Figure
    from PIL import Image

    from odsuite_plugins.renderers.report import FIGURE_DPI, _palette_png

    x = np.linspace(0, 1, 400)
    colours = [colormaps["hsv"](k / 40) for k in range(40)]
    fig = Figure(figsize=(6.5, 4))
    ax = fig.subplots()
    for k, c in enumerate(colours):
        ax.plot(x, np.sin(2 * np.pi * (k + 1) * x) + k, lw=1, color=c)
    path = tmp_path / "lines.png"
    fig.savefig(path, dpi=FIGURE_DPI)
    with Image.open(path) as a:
        original = np.asarray(a.convert("RGB")).astype(int)
    _palette_png(path)
    with Image.open(path) as b:
        shown = np.asarray(b.convert("RGB")).astype(int)
    drawn = set()
    for c in colours:
        rgb = np.round(np.array(c[:3]) * 255).astype(int)
        line = np.all(np.abs(original - rgb) <= 1, axis=2)  # the line's own pixels, not its antialiased edge
        assert line.sum() >= 10, c
        assert np.abs(shown[line] - rgb).max() <= 8, (rgb, np.abs(shown[line] - rgb).max())
        drawn.add(tuple(np.median(shown[line], axis=0)))
    assert len(drawn) == len(colours)


def test_a_movie_shorter_than_its_frame_count_gets_its_last_frame_as_poster(tmp_path):
    """The poster is the frame a third of the way in; a file that decodes fewer frames than the
    renderer counted gets its last one, not a traceback."""
    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")
    from PIL import Image

    from odsuite_plugins.renderers.report import _poster

    size, levels = (64, 48), (30, 120, 220)
    writer = imageio_ffmpeg.write_frames(str(tmp_path / "m.mp4"), size, fps=10, macro_block_size=16)
    writer.send(None)
    for level in levels:
        writer.send(np.full((size[1], size[0], 3), level, np.uint8).tobytes())
    writer.close()
    poster = _poster(tmp_path / "m.mp4", 30, tmp_path / "poster.png")
    grey = np.asarray(Image.open(poster)).mean()
    assert abs(grey - levels[-1]) < 6
    # where the frame a third of the way in exists, it is the one shown
    poster = _poster(tmp_path / "m.mp4", 3, tmp_path / "poster2.png")
    assert abs(np.asarray(Image.open(poster)).mean() - levels[1]) < 6


def test_the_driving_point_measures_along_the_blow():
    """A blow along -x at a frame's end: the single-axis z sensor 0.12 m away is nearer than the
    triaxial sensor 0.21 m away, but sees little of the blow; the driving point is the triaxial's x
    axis (the report drew the z sensor's FRF, which was noise). Without any sensor along the blow,
    the nearest one is kept."""
    from types import SimpleNamespace

    from odsuite_plugins.renderers.report import driving_point

    def sensor(position, axis):
        return SimpleNamespace(position=np.array(position), axis=np.array(axis, float))

    triaxial = [sensor([0.95, -0.15, 0.17], a) for a in np.eye(3)]
    z_near = sensor([0.95, 0.15, 0.17], [0, 0, 1])
    point, direction = np.array([1.0, 0.05, 0.11]), np.array([-1.0, 0.0, 0.0])
    exp = SimpleNamespace(sensors=[z_near, *triaxial], point=point, direction=direction)
    assert np.linalg.norm(z_near.position - point) < np.linalg.norm(triaxial[0].position - point)
    assert driving_point(exp) == 1  # the triaxial's x axis
    sideways = SimpleNamespace(sensors=[z_near, triaxial[1]], point=point, direction=direction)
    assert driving_point(sideways) == 0


def test_a_force_direction_prints_no_negative_zero():
    """The -x blow of T5 read (-1.00, -0.00, -0.00) in the experiments table."""
    from odsuite_plugins.renderers.report import _direction

    assert _direction(-np.array([1.0, 0.0, 0.0])) == "(-1.00, +0.00, +0.00)"
    assert _direction([0.0, -1e-17, 1.0]) == "(+0.00, +0.00, +1.00)"
    assert _direction([0.6, -0.8, 0.0]) == "(+0.60, -0.80, +0.00)"


def test_the_report_movie_plays_at_its_rate_as_a_gif_too():
    """A GIF's frame delays are whole hundredths of a second: the report's 15 fps played at 14.29
    when the movie fell back to GIF; its rate is one a GIF plays exactly."""
    from odsuite_plugins.renderers.movie import playback_fps
    from odsuite_plugins.renderers.report import MOVIE_FPS

    assert playback_fps(MOVIE_FPS, "gif") == (MOVIE_FPS, None) == playback_fps(MOVIE_FPS, "mp4")
