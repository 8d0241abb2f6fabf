"""Records that start at their hit (no samples before it) under 1/f noise or a floor's vibration.
No samples before the hit tell the noise's colour, so the floor is white, and a perfect model's
residual at 2.5-12.5 Hz read 7.3x it: nulls said "unexplained" (the calibration's pre-trigger-0
nulls: 2 of 12 under 1/f noise, 5 of 12 under a floor's vibration). The model's residual on the
records' quiet tails shows that noise, but a softer mount still ringing there shows alike, so the
tails decide only where nothing explains the cells (diagnose._held_by_tails): the verdict is then
"nothing to explain" with those cells named as not judged, and a fault a candidate explains is
named as before."""

from __future__ import annotations

import pytest

from . import calibrate


def _spec(case: str, seed: int, disturbances: list[str], **noise) -> dict:
    return {"case": case, "rig": "plate-motor", "seed": seed, "force_n": calibrate.FORCES[seed % 5],
            "disturbances": disturbances, "set": "nulls" if case == "null" else "faults", "pre_trigger": 0,
            "id": f"{case}-s{seed}-pre0", **noise}


def test_a_null_recorded_from_its_hit_under_flicker_noise_has_nothing_to_explain(tmp_path):
    # calibrate --set nulls --n 12 --pre-trigger 0 --disturb flicker: case s105 (5 N, noise 1 %)
    result = calibrate.run_one(_spec("null", 105, ["flicker"], noise_fraction=0.01), tmp_path)
    assert "error" not in result, result.get("error")
    d = result["diagnosis"]
    assert d["verdict"] == "nothing to explain" and not d["significant"], (d["verdict"], d.get("cells"))
    assert "records' quiet tails holds as much" in d["message"]


def test_a_softer_mount_recorded_from_its_hit_is_still_named(tmp_path):
    # calibrate --set faults --n 20 --pre-trigger 0: case s210 (10 N, 17.5x its noise at its strongest
    # band), missed when the tails' noise set the floor of every test
    spec = calibrate.specs("faults", 20)[10] | {"pre_trigger": 0}
    assert spec["seed"] == 210 and spec["case"] == "softer-mount", spec
    result = calibrate.run_one(spec, tmp_path)
    assert "error" not in result, result.get("error")
    d = result["diagnosis"]
    assert d["verdict"] == "explained" and d["top"]["effect"] == "stiffness", (d["verdict"], d["top"])
