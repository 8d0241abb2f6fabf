"""The detection matrix: hidden changes drawn at random by the independent generator (mode shapes
with in-plane parts, torsion, a loose bracket, tilts up to 40 degrees, scan skews and channel
delays, force-level series on hardening springs), on both of its rigs; ``diagnose`` must put the
right effect on top, or a candidate that names it as confounded, and call it significant.

The fast rows (in `make test`) run three cases on the thesis rig against the effects the issue
saw winning in their place; the slow rows (`make stress`) run every case on both rigs against
every registered effect.
"""

from __future__ import annotations

import numpy as np
import pytest

from . import cases
from .projects import case_project

#: which effects explain each case: the physics the generator simulated, in the library's names
RIGHT = {
    "flexible-mode": {"missing_mode", "coupled_mode", "plate_flexibility", "plate_flexibility_free"},
    "torsion-mode": {"missing_mode", "coupled_mode", "plate_flexibility", "plate_flexibility_free"},
    "loose-bracket": {"missing_mode", "coupled_mode", "mounted_mode", "plate_flexibility_free"},
    "sensor-tilt": {"sensor_orientation"},
    "scan-skew": {"scan_skew", "channel_delay"},
    "channel-delay": {"channel_delay"},
    "hardening-series": {"nonlinear_stiffness"},
}
#: samples per record: enough for the slowest rig's response to die away (half the two-body
#: default); the fast rows on the thesis rig, whose response dies within 0.1 s, take half of it
N_SAMPLES = 4096
N_SAMPLES_FAST = 2048


def _diagnose(tmp_path, name: str, rig: str, seed: int, effects=None, n_samples: int = N_SAMPLES):
    from odsuite.diagnosis.diagnose import diagnose
    from odsuite.store.project import open_project

    project, truth = case_project(cases.build_case(name, seed, rig, n_samples=n_samples), tmp_path)
    with open_project(project) as p:
        return diagnose(p, effects=effects), truth


#: a hidden change whose error stays below this multiple of the noise floor is not in the data
#: clearly enough to demand its detection (a small delay on a channel that barely moves)
DETECTABLE = 1.5


def _check(d, name: str, truth) -> None:
    top = d.candidates[0]
    table = [(c.effect, c.significant, round(c.validated_error, 4), c.confounded_with) for c in d.candidates[:5]]
    # the row as the note's matrix shows it (pytest -rA prints it)
    print(f"{name}: verdict {d.verdict!r}, error/floor {d.baseline_error / d.noise_floor_error:.2f} -> "
          f"{top.validated_error / d.noise_floor_error:.2f}, top {top.effect} {top.confounded_with}, truth {truth['effect']}")
    if d.baseline_error < DETECTABLE * d.noise_floor_error:  # then no wrong effect may be declared
        wrong = [c.effect for c in d.candidates if c.significant and not ({c.effect, *c.confounded_with} & RIGHT[name])]
        assert not wrong, (truth["effect"], d.baseline_error, d.noise_floor_error, table)
        return
    # an accepted pair "A+B" names both (as the calibration counts it)
    named = set(top.effect.split("+")) | set(top.confounded_with)
    assert named & RIGHT[name], (truth["effect"], table)
    assert top.significant, table
    assert top.validated_error < d.baseline_error
    # the physics is in the library: the verdict credits it, fully or in part, and never says the
    # data hold nothing or that nothing explains them
    assert d.verdict in ("explained", "partly explained"), (d.verdict, table)


@pytest.mark.parametrize(("name", "seed", "effects"), [
    # a 1099 Hz bending mode with in-plane parts: the issue saw plate_flexibility stop at 0.44
    ("flexible-mode", 1, ["missing_mode", "plate_flexibility", "stiffness"]),
    # a 39.8 degree tilt: the issue saw sensor_gain win and sensor_orientation stop at 4.9 degrees
    ("sensor-tilt", 7, ["sensor_orientation", "sensor_gain"]),
    # an 8 us scan skew: the issue saw a 4.8 kHz sensor resonance declared
    ("scan-skew", 1, ["scan_skew", "sensor_dynamics"]),
])
def test_the_right_effect_tops_its_rivals(tmp_path, name, seed, effects):
    d, truth = _diagnose(tmp_path, name, "thesis", seed, effects, N_SAMPLES_FAST)
    _check(d, name, truth)
    effect = truth["effect"]
    top = d.candidates[0]
    if name == "sensor-tilt":  # the angle itself (measured: 39.8 degrees fitted for 39.8)
        angle = np.degrees(np.hypot(top.parameters[f"{effect['sensor']}_tilt_a"],
                                    top.parameters[f"{effect['sensor']}_tilt_b"]))
        assert angle == pytest.approx(effect["angle_deg"], abs=1.5)
    elif name == "scan-skew":  # measured: 7.92 us fitted for 7.94
        assert top.parameters["skew_s"] == pytest.approx(effect["skew_per_channel_s"], rel=0.03)
    else:  # measured: 1101 Hz fitted for 1099
        assert top.parameters["frequency_hz"] == pytest.approx(effect["frequency_hz"], rel=0.01)


def test_a_plate_mode_that_moves_the_springs_is_explained_with_the_rigs_frequencies(tmp_path):
    """A 367 Hz plate mode of random shape whose shape moves the spring attachments (seed 22): the
    springs couple it to the 200-300 Hz rigid modes. missing_mode's uncoupled mode stopped at 10.7x
    the floor; coupled_mode, fitted from it, must bring the error to the floor, and the fitted
    model's natural frequencies must be the true structure's (the generator's own eigenvalues)."""
    from .rigsim import Model as TrueModel

    case = cases.build_case("flexible-mode", 22, "thesis", n_samples=N_SAMPLES_FAST)
    d, truth = _diagnose(tmp_path, "flexible-mode", "thesis", 22,
                         ["missing_mode", "coupled_mode", "plate_flexibility_free"], N_SAMPLES_FAST)
    _check(d, "flexible-mode", truth)
    top = d.candidates[0]
    assert top.effect == "coupled_mode" and d.verdict == "explained", [(c.effect, c.validated_error) for c in d.candidates]
    assert top.validated_error < 1.3 * d.noise_floor_error
    # significant over missing_mode's fit, so told apart from it (not "confounded")
    assert "missing_mode" not in top.confounded_with
    fitted = np.sort(next(iter(top._problem.models(top._u).values())).modes().frequency_hz)
    true = np.sort(TrueModel(case.actual.structure).natural_frequencies())
    print("fitted", np.round(fitted, 1), "true", np.round(true, 1))
    assert fitted == pytest.approx(true, rel=0.01)


def test_a_loose_bracket_is_a_part_whose_mass_pulls_on_the_plate(tmp_path):
    """The sensors at point 1 on a 18 g block on four small springs, soft along z (1331 Hz), seed
    21: the block's motion is driven by the plate's and pulls back on it. missing_mode's mode,
    driven by the hammer, stopped at 3.5x the floor (4096 samples); mounted_mode, fitted from it,
    must take the biggest step, find the block at point 1, its frequency on a held plate and its
    mass (the share over the participations' square there)."""
    d, truth = _diagnose(tmp_path, "loose-bracket", "thesis", 21,
                         ["missing_mode", "coupled_mode", "mounted_mode"], N_SAMPLES_FAST)
    _check(d, "loose-bracket", truth)
    top = d.candidates[0]
    errors = {c.effect: c.validated_error for c in d.candidates}
    assert top.effect == "mounted_mode" and top.significant, errors
    assert errors["mounted_mode"] < 0.7 * errors["missing_mode"], errors
    assert "missing_mode" not in top.confounded_with
    v = top.parameters
    assert v["frequency_hz"] == pytest.approx(truth["effect"]["frequency_hz"], rel=0.02)
    shares = {k.removeprefix("part_"): x for k, x in v.items() if k.startswith("part_")}
    assert max(shares, key=shares.get) == "x1_z1", shares
    mass = shares["x1_z1"] / (v["phi_x1"] ** 2 + v["phi_z1"] ** 2)
    print(f"part mass {1e3 * mass:.1f} g (true {1e3 * truth['effect']['mass_kg']:.1f} g), shares {shares}")
    # measured: 16.6 g for 18.4 g (2048 samples)
    assert mass == pytest.approx(truth["effect"]["mass_kg"], rel=0.25)


@pytest.mark.slow
@pytest.mark.parametrize("rig", ["thesis", "two-body"])
@pytest.mark.parametrize("name", sorted(RIGHT))
@pytest.mark.parametrize("seed", [21, 22])
def test_detection_matrix(tmp_path, name, rig, seed):
    d, truth = _diagnose(tmp_path, name, rig, seed)
    _check(d, name, truth)


def test_hardening_on_a_slow_rig_survives_screening(tmp_path):
    """Cubic hardening on the two-body rig (an 11 Hz suspension): the hardening's global starts
    must be compared where the response has turned. Compared on the 10 ms head (a ninth of the
    slowest period) a thousandfold hardened isolator looked best, the damped steps on the longer
    heads could not undo it, and the screening returned the nominal model: nonlinear_stiffness was
    never fitted (measured, seed 21: screened at 2.02x the floor, as the baseline)."""
    from odsuite.diagnosis.fitting import Problem, fit_windows, screen
    from odsuite.analysis.modelrev import current_revision, revision_model
    from odsuite.contracts.plugins import registries
    from odsuite.analysis.prediction import prepare
    from odsuite.store.project import open_project

    project, truth = case_project(cases.build_case("hardening-series", 21, "two-body", n_samples=N_SAMPLES), tmp_path)
    with open_project(project) as p:
        exps = prepare(p, None)[::2]  # three of the five force levels (0.6, 5.3, 47 N): half the cost
        base = revision_model(p, current_revision(p))
    problem = Problem(base, registries().effects.get("nonlinear_stiffness"), fit_windows(exps), full=exps)
    sse0 = problem.sse(problem.zero())
    s = screen(problem, sse0, ())
    # measured: the sum of squares falls to 0.30 of the baseline's, the mounts at 0.1 (mount3 0.01),
    # the isolators at 0.01 or below
    values = {f.param.name.removeprefix("hardening_"): f.to_value(u) for f, u in zip(s.problem.free, s.u0)}
    print(f"screened sum of squares {s.sse / sse0:.3f} of the baseline's; {values}")
    assert s.sse < 0.8 * sse0, (s.sse, sse0)
    group = set(truth["effect"]["cubic_n_per_m3"])
    assert max(values, key=values.get) in group, (values, group)
