"""The loop on every rig shipped in projects/rigs, through the command line only, with a hidden
change recorded by the simulated rig from an edited copy of the rig file (`acquire --truth`): the
user's own hidden-effect exercise. (The two-body rig's loop on independently written .lvm files is
in test_any_rig_loop.py.)"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from tests.cli.clirun import run_ok as run

pytestmark = pytest.mark.slow
RIGS = Path(__file__).resolve().parents[2] / "projects" / "rigs"
#: the thesis rig and its Systeminfo ship once, with the models plugin that registers them
PLUGIN_RIGS = Path(__file__).resolve().parents[2] / "plugins" / "models" / "rigs"


def test_thesis_rig_stiffer_vertical_springs_are_found_and_fixed(capsys, tmp_path):
    rig = PLUGIN_RIGS / "thesis-dynamometer.toml"
    text = rig.read_text()
    assert text.count("stiffness = [262000.0, 262000.0, 1260000.0]") == 4
    # every spring 30 % stiffer vertically: 1.26 -> 1.638 MN/m
    (tmp_path / "stiffer.toml").write_text(text.replace("1260000.0]", "1638000.0]"))
    shutil.copy(PLUGIN_RIGS / "thesis-table-e3.CTR", tmp_path)
    truth = tmp_path / "stiffer.toml"
    records = []
    for test in ("T1", "T2", "T3", "T4", "T5"):
        records.append(["--daq", "sim", "--name", test, "--samples", "8192", "--scenario", test, "--seed", "3"])
    p = tmp_path / "p.h5"
    run(capsys, "new", p, "--rig", rig)
    for r in records:
        run(capsys, "acquire", p, *r, "--truth", truth)
    run(capsys, "process", p)
    diagnosis = json.loads(run(capsys, "diagnose", p, "--json"))
    top = diagnosis["candidates"][0]
    assert top["effect"] == "stiffness" and top["significant"]
    assert diagnosis["baseline_error"] > 5 * diagnosis["noise_floor_error"]
    run(capsys, "add-effect", p, "stiffness")
    scales = json.loads(run(capsys, "model", p, "--json"))["parameters"]["stiffness"]
    # a spring's stiffness along an axis is the axis scale times the spring's own scale
    for k in range(1, 5):
        spring = scales[f"scale_spring{k}"]
        assert scales["scale_z"] * spring == pytest.approx(1.3, rel=0.02), scales
        assert scales["scale_x"] * spring == pytest.approx(1.0, abs=0.05), scales
    after = json.loads(run(capsys, "compare", p, "--json"))
    # the reference: the same records compared with the true model (a project on the changed rig)
    perfect = tmp_path / "perfect.h5"
    run(capsys, "new", perfect, "--rig", truth)
    for r in records:
        run(capsys, "acquire", perfect, *r)
    run(capsys, "process", perfect)
    best = json.loads(run(capsys, "compare", perfect, "--json"))
    assert diagnosis["baseline_error"] > 10 * best["error"]
    assert after["error"] <= 1.1 * best["error"], (after["error"], best["error"])


#: two blows per shipped rig: (force point mm, direction, extra acquire options)
BLOWS = {
    "thesis-dynamometer.toml": [("-0.795,79.089,-11.4", "+z", ["--samples", "4096"]),
                                ("20,30,-11.4", "+z", ["--samples", "4096"])],
    "two-body-machine.toml": [("50,20,250", "-z", ["--samples", "4096"]), ("-150,0,130", "+x", ["--samples", "4096"])],
    "thesis-car-2dof.toml": [("1300,0,700", "-z", ["--samples", "4096", "--trigger-level", "20", "--force-peak",
                                                    "3000", "--contact-ms", "30"]),
                             ("-1600,300,700", "-z", ["--samples", "4096", "--trigger-level", "20", "--force-peak",
                                                      "3000", "--contact-ms", "30"])],
}


#: shipped rigs whose loop runs on real records in their own test; a rig without a model (the
#: building's floors: operating shapes only, nothing to compare) where its records are laid onto it
ELSEWHERE = {"ladisk-beam.toml": "test_beam_loop.py",
             "palisaden-floors.toml": "../plugins/renderers/test_shape_movie.py"}


def test_every_shipped_rig_has_a_loop_test():
    assert sorted([*BLOWS, *ELSEWHERE]) == sorted(p.name for p in [*RIGS.glob("*.toml"), *PLUGIN_RIGS.glob("*.toml")])
    assert all(rig in (Path(__file__).parent / test).read_text() for rig, test in ELSEWHERE.items())


@pytest.mark.parametrize("rig_name", sorted(BLOWS))
def test_a_perfect_model_is_at_the_noise_floor(capsys, tmp_path, rig_name):
    p = tmp_path / "p.h5"
    run(capsys, "new", p, "--rig", next(d / rig_name for d in (RIGS, PLUGIN_RIGS) if (d / rig_name).is_file()))
    for k, (point, direction, extra) in enumerate(BLOWS[rig_name]):
        run(capsys, "acquire", p, "--name", f"b{k}", f"--force-point={point}", f"--force-dir={direction}",
            "--seed", str(k + 1), *extra)
    run(capsys, "process", p)
    result = json.loads(run(capsys, "compare", p, "--json"))
    assert result["error"] <= 1.5 * result["noise_floor"], (result["error"], result["noise_floor"])


def test_car_softer_rear_suspension_is_found_and_fixed(capsys, tmp_path):
    rig = RIGS / "thesis-car-2dof.toml"
    text = rig.read_text()
    # the rear spring 20 % softer: 37.9 -> 30.4 kN/m (a worn spring, a heavy load in the boot)
    assert "stiffness = [0.0, 0.0, 37944.147644]" in text
    truth = tmp_path / "worn.toml"
    truth.write_text(text.replace("stiffness = [0.0, 0.0, 37944.147644]", "stiffness = [0.0, 0.0, 30355.318115]"))
    p = tmp_path / "p.h5"
    run(capsys, "new", p, "--rig", rig)
    for k, (point, direction, extra) in enumerate(BLOWS["thesis-car-2dof.toml"] + [("0,0,700", "-z", [
            "--samples", "4096", "--trigger-level", "20", "--force-peak", "3000", "--contact-ms", "30"])]):
        run(capsys, "acquire", p, "--name", f"b{k}", f"--force-point={point}", f"--force-dir={direction}",
            "--seed", str(k + 1), "--truth", truth, *extra)
    run(capsys, "process", p)
    diagnosis = json.loads(run(capsys, "diagnose", p, "--json"))
    top = diagnosis["candidates"][0]
    assert top["effect"] == "stiffness" and top["significant"] and diagnosis["verdict"] == "explained"
    run(capsys, "add-effect", p, "stiffness")
    s = json.loads(run(capsys, "model", p, "--json"))["parameters"]["stiffness"]
    assert s["scale_z"] * s["scale_rear"] == pytest.approx(0.8, rel=0.02), s
    assert s["scale_z"] * s["scale_front"] == pytest.approx(1.0, rel=0.02), s
    after = json.loads(run(capsys, "compare", p, "--json"))
    assert after["error"] <= 1.5 * after["noise_floor"]
