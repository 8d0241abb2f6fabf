"""Nulls with a floor's vibration in every record (the generator's ``ambient`` disturbance: a noise
band at 8-40 Hz, quality 2-5, 3x the white noise's rms on every accelerometer channel). The floor's
law white + rise cannot hold a band: fitted to it, a perfect model's cells in the band's octave read
1.02-1.18x their limit and the verdict said "unexplained". The floor now carries each band's excess
where every sensor's samples before the hit, pooled, show it (noise_colour.shared_excess), and
judges a band only where those samples show lines the fitted hum leaves (noise_floor.witnesses)."""

from __future__ import annotations

import numpy as np
import pytest

from . import calibrate


def _strongest(tmp_path, spec):
    """The strongest judged cell of the nominal model over its limit (amplitude), and its band."""
    from odsuite import open_project
    from odsuite.analysis import resolved
    from odsuite.analysis.comparison import compare
    from odsuite.analysis.prediction import prepare

    with open_project(calibrate.project_of(spec, tmp_path)) as p:
        exps = prepare(p)
        cmp = compare(p, prepared=exps, resonances=False, coordinates=False, tables=False)
    res = resolved.resolve(exps, cmp.predictions, cmp.floor)
    best = (0.0, None)
    for q, lim, bands in zip(res.ratios(), res.limit, res.bands):
        ratio = np.where(np.isfinite(lim), np.sqrt(q / lim), 0.0)
        b, c = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
        best = max(best, (float(ratio[b, c]), bands[b]), key=lambda x: x[0])
    return best


@pytest.mark.parametrize("rig, seed, before", [("cabinet", 104, 1.17), ("plate-motor", 102, 1.08), ("skid", 105, 1.07)])
def test_a_null_with_floor_vibration_has_no_cell_above_its_limit(tmp_path, rig, seed, before):
    # cabinet: a band at 8.5 Hz (quality 2.2), 30 N, 3 % noise; plate-motor: 27.8 Hz (4.1), 30 N, 50 uV;
    # skid: 5 N, 3 % noise, 130 samples before each hit at 2 kHz: the 25-50 Hz band's noise is measured
    # on 4 lines, whose error the limit now carries (resolved.floor_error)
    spec = calibrate.specs("nulls", 9 if rig == "plate-motor" else 8,
                           ("thesis", "two-body", "plate-motor") if rig == "plate-motor" else ("cabinet", "skid"))
    spec = next(s for s in spec if s["seed"] == seed)
    spec["disturbances"] = [*spec.get("disturbances", []), "ambient"]
    spec["id"] += "-ambient"
    strongest, band = _strongest(tmp_path, spec)
    assert strongest < 1.0, (strongest, band, before)
