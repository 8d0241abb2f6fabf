"""Nulls under 1/f sensor noise (the generator's ``flicker`` disturbance: density the white level's
times corner / f, corners 20-200 Hz, as an IEPE accelerometer's rises at low frequency). With a
white floor a perfect model's residual at 2.5-25 Hz read 4.6-7.1x its floor there and the verdict
said "unexplained" (these two of 15 such nulls, both on the plate-motor rig, whose 0.4 s records
resolve those bands); the floor now carries the rise the samples before the hit show
(odsuite.analysis.noise_colour), and judges a band only where the samples before the hit show two
lines in it."""

from __future__ import annotations

import pytest

from . import calibrate


@pytest.mark.slow
@pytest.mark.parametrize("seed", [102, 105])
def test_a_null_under_flicker_noise_has_nothing_to_explain(tmp_path, seed):
    spec = {"case": "null", "rig": "plate-motor", "seed": seed, "force_n": calibrate.FORCES[seed % 5],
            "disturbances": ["flicker"], "set": "nulls", "id": f"flicker-null-s{seed}"}
    spec |= {"noise_v": 50e-6} if seed == 102 else {"noise_fraction": 0.01}
    result = calibrate.run_one(spec, tmp_path)
    assert "error" not in result, result.get("error")
    d = result["diagnosis"]
    assert d["verdict"] == "nothing to explain" and not d["significant"], (d["verdict"], d.get("cells"))


@pytest.mark.slow
@pytest.mark.parametrize("seed", [100, 107])
def test_a_null_under_flicker_noise_on_the_cabinet_has_nothing_to_explain(tmp_path, seed):
    # the calibration's cabinet nulls (`--set nulls --rigs cabinet --disturb flicker`): 5 of 8 read
    # "unexplained" when one band ran from 1.5 to 12.5 Hz, judged on the 11.7 Hz line of the 0.085 s
    # before each hit (s107: 1.48x its limit), and when the quiet tails alone decided that 1.5-6.25 Hz
    # was judged, though the floor's colour is not measured from them (s100: 1.37x)
    spec = calibrate.specs("nulls", 8, ("cabinet",))[seed - 100]
    spec["disturbances"] = [*spec.get("disturbances", []), "flicker"]
    spec["id"] += "-flicker"
    result = calibrate.run_one(spec, tmp_path)
    assert "error" not in result, result.get("error")
    d = result["diagnosis"]
    assert d["verdict"] == "nothing to explain" and not d["significant"], (d["verdict"], d.get("cells"))
