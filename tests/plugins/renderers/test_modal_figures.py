"""The modal figures of the renderers plugin, drawn from closed forms and read back from the
matplotlib Figure; and the figure renderers the commands ask the registry for."""

import numpy as np
import pytest

from odsuite.cli import main


def test_mac_figure_writes_every_value(tmp_path):
    from odsuite.analysis.modal import mac
    from odsuite_plugins.renderers.modal_figures import mac_figure

    phi = np.array([[1.0, 1.0, 0.5], [1.0, -1.0, 0.5], [0.0, 0.2, 1.0]])
    m = mac(phi, phi)
    fig = mac_figure(m, tmp_path / "mac.svg", labels_a=["a1", "a2", "a3"], labels_b=["b1", "b2", "b3"])
    texts = [t.get_text() for t in fig.axes[0].texts]
    assert texts == [f"{v:.2f}" for v in m.ravel()]
    # by hand: |a.c|^2 / (a.a c.c) = 1 / (2 x 1.5); a and b are orthogonal
    assert texts[:3] == ["1.00", "0.00", "0.33"]
    assert (tmp_path / "mac.svg").read_text().lstrip().startswith("<?xml")


def test_frf_figure_log_frequency_axes_units_and_print_type(tmp_path):
    """A closed-form SDOF accelerance (m = 2 kg, k = 8e5 N/m, ζ = 2 %): the magnitude drawn is
    |H| on log-log axes, phase and coherence on the same log frequency axis, the FRF unit on the
    magnitude axis, the model mode dotted; at 6.5 in wide no type is below 8 pt."""
    from matplotlib.text import Text

    from odsuite.analysis.frf import FrfSet
    from odsuite_plugins.renderers.modal_figures import frf_figure

    m, k, zeta = 2.0, 8e5, 0.02
    fn = np.sqrt(k / m) / (2 * np.pi)  # 100.7 Hz
    f = np.linspace(0.0, 2000.0, 4001)
    w = 2 * np.pi * f
    h = -(w**2) / (k - m * w**2 + 2j * zeta * np.sqrt(k * m) * w)
    frf = FrfSet(f, h[None, :], np.full((1, f.size), 0.99), "H1", ["(m/s^2)/N"], ["a1"], 5)
    fig = frf_figure(frf, tmp_path / "frf.png", band_hz=(20.0, 1000.0), model_hz=[fn], size=(6.5, 5.2), dpi=90)
    mag, phase, coh = fig.axes
    assert [a.get_xscale() for a in fig.axes] == ["log"] * 3 and mag.get_yscale() == "log"
    assert mag.get_ylabel() == "|H| [(m/s²)/N]" and coh.get_xlabel() == "frequency [Hz]"
    assert np.allclose(mag.lines[0].get_ydata(), np.abs(h[1:]))
    peak = mag.lines[0].get_xdata()[np.argmax(mag.lines[0].get_ydata())]
    assert abs(peak - fn) < 1.0  # the resonance where the closed form puts it
    assert any(np.allclose(ln.get_xdata(), fn) for ln in mag.lines[1:])  # the model mode, dotted
    texts = [t for t in fig.findobj(Text) if t.get_visible() and t.get_text().strip()]
    assert min(t.get_fontsize() for t in texts) >= 8.0
    assert (tmp_path / "frf.png").stat().st_size > 0


def test_frf_figure_draws_the_models_frf_and_phase_only_where_coherence_is_good(tmp_path):
    """The measured FRF is a closed-form SDOF accelerance (m = 2 kg, k = 8e5 N/m, ζ = 2 %), the
    model's the same with k 10 % lower: the model's line is its magnitude and phase; the measured
    phase is left out (NaN, shaded) where the coherence is below 0.8 and drawn where it is not."""
    from odsuite.analysis.frf import FrfSet
    from odsuite_plugins.renderers.modal_figures import COHERENCE_GOOD, frf_figure

    m, zeta = 2.0, 0.02
    f = np.linspace(0.0, 1000.0, 2001)
    w = 2 * np.pi * f

    def sdof(k):
        return -(w**2) / (k - m * w**2 + 2j * zeta * np.sqrt(k * m) * w)

    h, h_model = sdof(8e5), sdof(7.2e5)
    coherence = np.where((f > 300.0) & (f < 500.0), 0.5, 0.99)
    frf = FrfSet(f, h[None, :], coherence[None, :], "H1", ["(m/s^2)/N"], ["a1"], 5)
    fig = frf_figure(frf, tmp_path / "frf.png", model_H={"a1": h_model}, size=(6.5, 5.2), dpi=90)
    mag, phase, coh = fig.axes
    model = [ln for ln in mag.lines if ln.get_label() == "model"]
    assert len(model) == 1 and np.allclose(model[0].get_ydata(), np.abs(h_model[1:]))
    def same_angle(deg, z):  # equal up to whole turns (the drawn phase is centred where it sits)
        return np.allclose(np.exp(1j * np.radians(deg)), z / np.abs(z))

    assert same_angle(phase.lines[1].get_ydata(), h_model[1:])
    measured_phase = phase.lines[0].get_ydata()
    bad = coherence[1:] < COHERENCE_GOOD
    assert np.all(np.isnan(measured_phase[bad]))
    assert same_angle(measured_phase[~bad], h[1:][~bad])
    # centred where the phase sits: the SDOF's -180 to 0 deg sweep (it starts at the +-180 deg
    # seam) is one line with no jump of a turn, within the axis
    model_phase = phase.lines[1].get_ydata()
    assert np.nanmax(np.abs(np.diff(model_phase))) < 90
    lo, hi = phase.get_ylim()
    assert lo <= np.nanmin(model_phase) and np.nanmax(model_phase) <= hi and hi - lo == pytest.approx(370.0)
    assert phase.patches  # the left-out lines are shaded


@pytest.fixture(scope="module")
def sim_project(tmp_path_factory):
    """One simulated hit (T1) on the thesis rig: revision 0 and its noise floor."""
    p = tmp_path_factory.mktemp("figures") / "p.h5"
    for argv in (["new", p], ["acquire", p, "--daq", "sim", "--name", "T1", "--seed", "2", "--samples", "2048"]):
        assert main([str(a) for a in argv]) == 0
    return p


def test_history_renderer_draws_the_projects_errors(sim_project, tmp_path, capsys, monkeypatch):
    """`history --figure` through the registry's `history` renderer: one bar per revision at the
    error `history --json` prints (the rigid model's NRMSE, computed independently by compare), the
    floor as a dashed line at its value; without the document the renderer reads it from the project."""
    import json

    from odsuite.analysis.comparison import compare
    from odsuite.contracts.plugins import registries
    from odsuite.contracts.renderers import RenderRequest
    from odsuite.store.project import open_project
    from odsuite_plugins.renderers import history_figure as module

    drawn = []
    original = module.history_figure
    monkeypatch.setattr(module, "history_figure", lambda *a, **k: drawn.append(original(*a, **k)) or drawn[-1])
    capsys.readouterr()
    assert main(["history", str(sim_project), "--json", "--figure", str(tmp_path / "h.png")]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert (tmp_path / "h.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    registries().renderers.get("history").render(RenderRequest(sim_project, None, tmp_path / "h.svg"))
    with open_project(sim_project) as p:
        error = compare(p).error
    for fig in drawn:
        ax = fig.axes[0]
        assert np.allclose([b.get_height() for b in ax.patches], [error], rtol=1e-9)
        assert np.allclose([r["error"] for r in doc["revisions"]], [error], rtol=1e-9)
        floor = [ln for ln in ax.lines if ln.get_linestyle() == "--"]
        assert len(floor) == 1 and np.allclose(floor[0].get_ydata(), doc["noise_floor_error"])
    assert len(drawn) == 2


def test_figure_renderer_without_its_numbers_says_where_they_come_from(sim_project, tmp_path, capsys):
    capsys.readouterr()
    out = tmp_path / "f.png"
    assert main(["render", str(sim_project), "T1", "-o", str(out), "--figure", "frf"]) == 1
    assert capsys.readouterr().err.strip() == ("error: renderer 'frf' draws the numbers it is given (option 'frf'), "
                                               "not a stored experiment: use `odsuite frf --figure`")
    assert not out.exists()


def test_frf_figure_draws_h1_without_the_records_straight_lines_from_three_cycles_up(tmp_path):
    """A single hit on a 47 kg body on a 9.5 Hz suspension (scipy.signal.lsim) read by an
    accelerometer drifting 0.009 m/s^2 per second: the figure draws H1 of the detrended records
    (scipy.signal.detrend), from the line of 3 cycles per record (1.5 Hz) up, and its title says so;
    without the records' trend known it draws from the first line, as before."""
    import dataclasses

    import scipy.signal

    from odsuite.analysis.frf import estimate_frf
    from odsuite_plugins.renderers.modal_figures import frf_figure

    fs, n, m, fn, zeta = 2048.0, 4096, 47.0, 9.5, 0.05
    k = m * (2 * np.pi * fn) ** 2
    t = np.arange(n) / fs
    x = (t - 0.1) / 0.004
    force = np.where((x >= 0) & (x <= 1), 200.0 * np.sin(np.pi * x) ** 2, 0.0)
    _, acc, _ = scipy.signal.lsim(scipy.signal.lti([1.0, 0.0, 0.0], [m, 2 * zeta * np.sqrt(k * m), k]), force, t)
    acc = acc + 0.05 + 0.009 * t
    frf = estimate_frf([force], [acc], fs, output_names=["z1"])
    fig = frf_figure(frf, tmp_path / "frf.png", size=(6.5, 5.2), dpi=90)
    mag = fig.axes[0]
    ref = estimate_frf([force], [scipy.signal.detrend(acc)], fs).H[0]
    assert mag.lines[0].get_xdata()[0] == pytest.approx(3 * fs / n)
    np.testing.assert_allclose(mag.lines[0].get_ydata(), np.abs(ref[3:]), rtol=1e-9)
    assert "straight line (offset, drift) removed, drawn from 3 cycles per record (1.5 Hz) up" in \
        mag.get_title().replace("\n", " ")
    unknown = frf_figure(dataclasses.replace(frf, trend=None), tmp_path / "raw.png")
    assert unknown.axes[0].lines[0].get_xdata()[0] == pytest.approx(fs / n)
    assert np.abs(unknown.axes[0].lines[0].get_ydata()[0]) > 50 * np.abs(ref[1])  # the drift, drawn raw


def test_a_phase_wrapping_at_the_axis_edge_is_not_drawn_as_a_spike():
    """A mass line's phase noisy about 180° wraps to -180° and back: the drawn line breaks there
    (no segment spans more than half a turn), and every line's value is kept."""
    from odsuite_plugins.renderers.modal_figures import _unjoined_wraps

    rng = np.random.default_rng(3)
    f = np.linspace(1.0, 100.0, 400)
    h = -np.exp(1j * np.radians(rng.normal(0.0, 2.0, f.size)))  # about 180°, either side
    degrees = np.degrees(np.angle(h))
    assert np.abs(np.diff(degrees)).max() > 300  # the raw phase jumps across the axis
    fx, px = _unjoined_wraps(f, degrees)
    drawn = np.isfinite(px[:-1]) & np.isfinite(px[1:])
    assert np.abs(np.diff(px))[drawn].max() <= 180.0
    assert np.array_equal(px[np.isfinite(px)], degrees) and np.array_equal(fx[np.isfinite(fx)], f)


def test_stabilisation_figure_keeps_its_legend_off_the_poles_and_counts_one_mode(tmp_path):
    """A closed-form SDOF accelerance (m = 2 kg, k = 8e5 N/m, ζ = 2 %): one mode, at 100.7 Hz;
    the title says "1 mode" (it said "1 modes") and the legend sits under the axes, where it
    covers no pole (inside, at lower right, it hid the low orders' poles)."""
    from odsuite.analysis.modal import identify_modes
    from odsuite_plugins.renderers.modal_figures import stabilisation_figure

    m, k, zeta = 2.0, 8e5, 0.02
    fn = np.sqrt(k / m) / (2 * np.pi)
    f = np.linspace(0.0, 1000.0, 2001)
    w = 2 * np.pi * f
    h = -(w**2) / (k - m * w**2 + 2j * zeta * np.sqrt(k * m) * w)
    h = h + 1e-4 * np.abs(h).max() * np.random.default_rng(0).standard_normal(f.size)
    res = identify_modes(f, h[None, :], f_band=(20.0, 400.0), max_order=20)
    assert res.frequency_hz == pytest.approx([fn], rel=1e-3) and res.damping_ratio == pytest.approx([zeta], rel=0.02)
    fig = stabilisation_figure(res, tmp_path / "stab.png", freq=f, H=h[None, :], title="sdof", size=(6.5, 4.5))
    ax = fig.axes[0]
    assert ax.get_title().startswith("sdof: 1 mode in 20-400\u00a0Hz")
    # wrapped, the unit stays with its number (the report's titles put "Hz" on a line alone)
    wrapped = stabilisation_figure(res, tmp_path / "wrapped.png", freq=f, H=h[None, :],
                                   title="T2: stabilisation diagram", size=(6.5, 4.5)).axes[0].get_title()
    assert len(wrapped.splitlines()) == 2 and wrapped.splitlines()[-1].strip() == "20-400\u00a0Hz", wrapped
    assert ax.get_legend() is None and len(fig.legends) == 1
    assert [t.get_text() for t in fig.legends[0].get_texts()] == ["new pole", "stable frequency",
                                                                 "stable frequency and damping"]
    fig.draw_without_rendering()  # the constrained layout as saved
    assert all(float(t).is_integer() for t in ax.get_yticks())  # model orders: no 2.5
    legend, axes = fig.legends[0].get_window_extent(), ax.get_window_extent()
    assert legend.y1 <= axes.y0, (legend, axes)  # wholly under the axes: no pole behind it


def test_stabilisation_mode_labels_sit_above_the_poles(tmp_path):
    """Each mode's label lies in the band above the highest order's poles: no pole is under it
    (drawn at the top orders, the labels hid the poles there)."""
    from odsuite.analysis.modal import identify_modes
    from odsuite_plugins.renderers.modal_figures import stabilisation_figure

    f = np.linspace(0.0, 1000.0, 2001)
    w = 2 * np.pi * f
    h = sum(-(w**2) / (k - m * w**2 + 2j * 0.02 * np.sqrt(k * m) * w) for m, k in ((2.0, 8e5), (1.0, 2.5e6)))
    h = h + 1e-4 * np.abs(h).max() * np.random.default_rng(1).standard_normal(f.size)
    res = identify_modes(f, h[None, :], f_band=(20.0, 600.0), max_order=20)
    assert len(res.frequency_hz) == 2
    fig = stabilisation_figure(res, tmp_path / "stab.png", freq=f, H=h[None, :], title="2 dof", size=(6.5, 4.5))
    fig.draw_without_rendering()
    ax = fig.axes[0]
    labels = [t for t in ax.texts if "ζ" in t.get_text()]
    assert len(labels) == 2
    poles = np.concatenate([ax.transData.transform(c.get_offsets()) for c in ax.collections
                            if len(c.get_offsets())])
    for label in labels:
        box = label.get_window_extent()
        under = (poles[:, 0] >= box.x0) & (poles[:, 0] <= box.x1) & (poles[:, 1] >= box.y0) & (poles[:, 1] <= box.y1)
        assert not under.any(), (label.get_text(), poles[under])
    # units in brackets, as every other picture writes them
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("frequency [Hz]", "model order")
