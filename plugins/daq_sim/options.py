"""The ``sim`` backend's own options and the limits their help names: what `odsuite plugins` and
`odsuite acquire` read without importing the simulator (numpy, the model)."""

from odsuite.contracts.backend_options import BackendOption  # not .daq: registering imports no more

#: ADC resolutions of real cards: 8-bit scopes to 24-bit sigma-delta (32 bits: the codes still
#: fit a float64's mantissa)
MIN_ADC_BITS, MAX_ADC_BITS = 8, 32
#: a thousand times the thesis's floor is a few volts of noise: beyond it the record is noise
MAX_NOISE_SCALE = 1000.0
#: peak forces hammers deliver (N): a miniature hammer's tap resolves a few mN; the heaviest drop
#: weights (pavement and bridge testers) strike with a few hundred kN. An operating load's rms
#: force (--force-rms) is bounded alike: no running machine or shaker drives a rig harder
MIN_PEAK_N, MAX_PEAK_N = 1e-3, 1e6
#: default rms of the ground's acceleration along each axis (m/s^2), white up to the simulator's
#: rate: the thesis rig's horizontal accelerometers (+-2.5 m/s^2 ranges) then peak near a third of
#: their range over 5 min, two hundred ADC codes rms above their noise
DEFAULT_BASE_RMS = 0.3

OPTIONS = (BackendOption("scenario", str, None, "thesis test T1..T8 (default T1 when no force point is given)"),
           BackendOption("seed", int, 0, "random seed; one seed, one record"),
           BackendOption("force_peak", float, None, f"peak hammer force in N, {MIN_PEAK_N:g} to {MAX_PEAK_N:g} "
                                                    "(default: the scenario's, else 20 N); several hits keep their "
                                                    "ratios"),
           BackendOption("contact_ms", float, None, "the blow's contact time, ms (default: the scenario's, "
                         "else 0.5 ms; a hard tip 0.1-0.5 ms, a rubber tip or a sledge 2-20 ms)"),
           BackendOption("truth_rig", str, None, "a rig file the record comes from instead of the project's rig "
                         "(a hidden change: stiffer mounts, a moved mass, a tilted or mis-calibrated sensor); "
                         "it has the project rig's channels (default: none, the project's rig)", flag="--truth"),
           BackendOption("adc_bits", int, None, f"ADC resolution, bits {MIN_ADC_BITS}-{MAX_ADC_BITS} "
                                                "(default 12: the thesis's E-series card)"),
           BackendOption("noise", float, 1.0, "scale of the ADC-input noise, offsets and drift "
                                              f"(1: the thesis's floor, 0: none, at most {MAX_NOISE_SCALE:g})"),
           BackendOption("operating", str, None, "a running machine instead of the hammer: random, sweep or "
                                                 "unbalance:HZ at the force point, or base-random: the ground "
                                                 "moving in all six directions (no force channel stored); default: none, "
                                                 "the hammer"),
           BackendOption("force_rms", float, None, f"operating: rms force in N, {MIN_PEAK_N:g} to {MAX_PEAK_N:g} "
                                                   "(default 0.5 N; unbalance: the rotating force's magnitude)"),
           BackendOption("base_rms", float, None, "base-random: rms ground acceleration in m/s^2 along each "
                                                  f"axis (default {DEFAULT_BASE_RMS:g} m/s^2); the rotations' rms is it "
                                                  "over the farthest accelerometer's distance from the rig origin"))
