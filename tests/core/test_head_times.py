"""The heads a fit starts on (fitting.head_times): 0.01 and 0.04 s after the hit, then longer ones
from half a period of the slowest mode that rings on through records long in its periods, and
shorter ones first from half a period of the lowest mode where it passes twice in 0.01 s. A mode
damped out within a few periods (a beam's bounce on lossy foam) does not make a record long: the
LADISK beam's shear and rotary inertia, a 2.3 % shift of its 3.7 kHz mode, was not found from a
first head of 30 ms, half a period of its 16 Hz bounce (docs/beam.md)."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from odsuite.diagnosis import fitting


def record(seconds: float, fs: float = 50_000.0) -> SimpleNamespace:
    return SimpleNamespace(n_samples=int(seconds * fs), trigger=0, fs=fs)


def problem(freqs_hz, zetas) -> SimpleNamespace:
    modes = SimpleNamespace(frequency_hz=list(freqs_hz), damping_ratio=list(zetas))
    return SimpleNamespace(base=SimpleNamespace(shared=SimpleNamespace(modes=lambda: modes)))


def test_a_beam_bouncing_on_lossy_foam_keeps_the_short_heads():
    # the LADISK rig at revision 0: bounce and pitch on the foam at 20 % damping (5.5 periods to a
    # thousandth), bending modes at 0.5 %; a 1 s record
    beam = problem([16.48, 24.87, 695.39, 1915.87], [0.2, 0.2, 0.005, 0.005])
    assert fitting.ringing_mode_hz(beam) == pytest.approx(695.39)
    # its bending modes ring 7 times in 0.01 s, but it bounces on soft foam: no shorter heads
    times = fitting.head_times([record(1.0)], fitting.ringing_mode_hz(beam), fitting.slowest_mode_hz(beam))
    assert times == [0.01, 0.04]
    # read from the slowest mode alone, the first head was 30 ms
    assert fitting.head_times([record(1.0)], fitting.slowest_mode_hz(beam))[0] == pytest.approx(0.5 / 16.48)


def test_a_cabinet_rocking_for_32_periods_gets_the_long_heads():
    # the tall cabinet: 5.4 Hz rocking at 0.9 % damping, 6 s records (tests/cli/test_one_soft_foot.py)
    cabinet = problem([5.404, 6.410, 20.66], [0.0091, 0.0112, 0.052])
    assert fitting.ringing_mode_hz(cabinet) == pytest.approx(5.404)
    times = fitting.head_times([record(6.0)], fitting.ringing_mode_hz(cabinet))
    assert times == pytest.approx([0.0925, 0.370, 1.480], rel=1e-3)


def test_undamped_and_rigid_modes():
    # an undamped mode rings for ever; a zero frequency (a free body) is no period at all
    assert fitting.ringing_mode_hz(problem([0.0, 3.0, 40.0], [0.0, 0.0, 0.01])) == 3.0
    assert fitting.ringing_mode_hz(problem([0.0, 10.0], [0.0, 0.5])) is None


def test_a_stiff_bracket_starts_from_half_a_period():
    # a 2 kg bracket on stiff pads (tests/data/rigs/stiff-bracket.toml): 306-832 Hz, 2-5 % damped;
    # 0.01 s holds three periods of its slowest mode, where a mass 1.75 times the model's put the
    # residual a cycle out of phase (tests/cli/test_stiff_rig_added_mass.py)
    bracket = problem([305.7, 330.8, 550.0, 636.6, 808.1, 831.7], [0.0193, 0.0221, 0.0419, 0.03, 0.049, 0.0473])
    times = fitting.head_times([record(0.32, 25_600.0)], fitting.ringing_mode_hz(bracket),
                               fitting.slowest_mode_hz(bracket))
    assert times == pytest.approx([0.5 / 305.7, 2 / 305.7, 0.01, 0.04])
    # two periods in the first head are not yet too many: the thesis rig's 97 Hz keeps its heads
    assert fitting.head_times([record(0.32, 25_600.0)], None, 200.0) == [0.01, 0.04]
    # nor does a rig whose modes are all damped out, with a 520 Hz plate mode fitted in
    thesis = problem([97.4, 98.3, 103.5, 216.9, 222.2, 227.5, 520.0], [0.16, 0.146, 0.169, 0.149, 0.161, 0.159, 0.02])
    assert fitting.head_times([record(0.41, 20_000.0)], fitting.ringing_mode_hz(thesis),
                              fitting.slowest_mode_hz(thesis)) == [0.01, 0.04]


def test_a_structure_ringing_near_nyquist_gets_no_heads_of_a_few_samples():
    # 5 kHz at 25.6 kHz: half a period is 2.6 samples; the heads start at 16 samples (0.625 ms)
    times = fitting.head_times([record(0.32, 25_600.0)], 5000.0, 5000.0)
    assert times == pytest.approx([16 / 25_600.0, 64 / 25_600.0, 0.01, 0.04])
    # at 2 kHz sampling 16 samples are 8 ms: a shorter head than 0.01 s would not add much
    assert fitting.head_times([record(2.0, 2000.0)], 500.0, 500.0) == [0.01, 0.04]
