"""End to end: a simulated record on the nominal truth, processed, agrees with the model driven by
the recorded force and processed the same way (like with like: both through Table E.3's chain).

A 16-bit ADC and no added noise: what remains is the analog chain (ICP high-passes and resonance act
on the accelerations, the load cell's on the force) and the sampling, which must not bias the
comparison. With the thesis's 12-bit card, a 15 N blow spans only ~140 codes of the force channel's
+-5 V range: the same comparison on T6 then gives 1.4 % (translations) and 1.0 % (rotations), and
added noise raises it further. Here 16 bits give 0.3-0.6 %.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from odsuite_plugins.daq_sim.simulator import SimulatedRig, default_chains

from odsuite.processing.acquisition import acquire
from odsuite.contracts.daq import AcquisitionSettings, rig_systeminfo
from odsuite.store.project import create_project


@pytest.mark.parametrize("scenario", ["T3", "T5", "T6"])
def test_processed_gencoords_match_the_models_within_2_percent(tmp_path, thesis_rig, scenario):
    from odsuite_plugins.daq_sim.truth import truth_model

    from odsuite.domain.model import Input, Output
    from odsuite.processing.pipeline import process_experiment
    from odsuite.domain.simulation import simulate

    with create_project(tmp_path / "p.h5") as project:
        chains = {k: replace(c, adc_bits=16) for k, c in
                  default_chains(thesis_rig, rig_systeminfo(thesis_rig, 20_000.0), noise=False).items()}
        exp, rec = acquire(project, SimulatedRig(), "meas", AcquisitionSettings(), scenario=scenario,
                           seed=11, noise=False, chains=chains)
        assert rec.clipped == {}
        process_experiment(project, "meas")
        force = project.read_derived("meas", "processed")["force"]
        # the model, driven by the recorded (processed) force, gives each sensor's acceleration
        model = truth_model(thesis_rig)
        sensors = thesis_rig.sensors
        acc = simulate(model, [Input.force(exp.excitation.point, exp.excitation.direction)], force,
                       exp.sampling_rate, [Output.sensor(s) for s in sensors], hold="foh")
        raw = exp.raw().copy()
        si = exp.systeminfo
        for i, s in enumerate(sensors):
            info = si.channels[s.channel]
            raw[:, s.channel] = s.sign * info.sensitivity * info.daq_gain * acc[:, i]
        project.add_experiment("model", raw, sampling_rate=exp.sampling_rate, systeminfo=si,
                               excitation=exp.excitation, pretrigger=exp.pretrigger,
                               channel_names=exp.channel_names)
        process_experiment(project, "model")
        meas = project.read_derived("meas", "gencoords")["platform_at_g"]
        ref = project.read_derived("model", "gencoords")["platform_at_g"]
    for cols in ((0, 1, 2), (3, 4, 5)):  # translations (m) and rotations (rad) pooled separately
        err = np.sqrt(np.sum((meas[:, cols] - ref[:, cols]) ** 2) / np.sum(ref[:, cols] ** 2))
        assert err < 0.02, (scenario, cols, err)
