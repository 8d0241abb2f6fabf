"""A sensor's parameters are differenced together with other sensors' (one evaluation moves one
parameter of every sensor) also where an experiment leaves a sensor out (a clipped channel): the
sensor's parameter changes nothing there, and every column equals its own evaluation's."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from hidden_effects import CASES, make_project


def test_sensor_columns_batched_where_an_experiment_leaves_a_sensor_out(tmp_path):
    import odsuite.diagnosis.fitting as fitting

    from odsuite.analysis.modelrev import revision_model
    from odsuite.analysis.prediction import prepare
    from odsuite.contracts.plugins import registries
    from odsuite.store.project import open_project

    path = make_project(tmp_path / "s.odsp", [("sensor_gain", CASES["sensor_gain"])], n_samples=2048)
    with open_project(path) as p:
        exps, base = prepare(p), revision_model(p)
    # the first experiment without x3, as prepare leaves a clipped channel out
    e0 = exps[0]
    keep = [j for j, s in enumerate(e0.sensors) if s.name != "x3"]
    assert len(keep) == len(e0.sensors) - 1
    exps[0] = replace(e0, sensors=[e0.sensors[j] for j in keep], columns=[e0.columns[j] for j in keep],
                      volts=e0.volts[:, keep], measured=e0.measured[:, keep], volts_per_unit=e0.volts_per_unit[keep],
                      chains=[e0.chains[j] for j in keep], noise_var=e0.noise_var[keep], units=[e0.units[j] for j in keep],
                      operators=None, lsb=e0.lsb[keep], adc_step_v=e0.adc_step_v[keep],
                      disturbance=e0.disturbance[:, keep], volts_disturbance=e0.volts_disturbance[:, keep], _cache=None)
    problem = fitting.Problem(base, registries().effects.get("sensor_gain"), fitting.fit_windows(exps), stride=2)
    sensors = {f.param.sensor for f in problem.free}
    assert "x3" in sensors and len(sensors) >= 3
    lo, hi = problem.lower_upper()
    u = np.clip(np.random.default_rng(5).normal(0.0, 0.5, len(problem.free)), lo, hi)
    r0 = problem.residual(u)
    before = problem.evaluations
    J = problem.jacobian(u, r0)
    per_sensor = max(sum(f.param.sensor == s for f in problem.free) for s in sensors)
    assert problem.evaluations - before == per_sensor  # x3's parameter moved with the others
    for i in range(len(problem.free)):
        du = np.zeros_like(u)
        du[i] = 1.0 if u[i] + 1.0 <= hi[i] else -1.0
        col = -(problem.residual(u + du, keep=False) - r0) / du[i]
        assert np.allclose(J[:, i], col, rtol=0, atol=1e-9 * np.abs(J).max()), problem.free[i].param.name
