"""Regenerate pyoma2_reference.json: pyOMA2's modes of the Palisaden record, as a peer reference.

Run in an environment with pyOMA2 (PyPI package ``pyOMA-2``; not an odsuite dependency)::

    python -m venv peer && peer/bin/pip install pyOMA-2==1.4.3
    peer/bin/python tests/data/real/palisaden_building/make_pyoma2_reference.py

The settings are those of pyOMA2's documentation, "Example2 - Real dataset", which gives the published
results quoted in README.md: high-pass Butterworth 0.1 Hz of order 8, decimation by 5 (100 Hz -> 20 Hz);
SSI-cov with 30 block rows, orders up to 30, uncertainty on (calc_unc=True), modes taken at order 20
nearest 1.88, 2.42 and 2.68 Hz; FSDD (and EFDD, FDD beside it) on Welch periodograms of 2048 samples
(102.4 s at 20 Hz) with 50 % overlap, the same three frequencies, MAC limit 0.95. The tests only read
the JSON; this script is how it was made. It prints each estimator's modes and its wall time.
"""

from __future__ import annotations

import json
import logging
import platform
import time
from importlib.metadata import version
from pathlib import Path

import numpy as np

logging.disable(logging.WARNING)

from pyoma2.algorithms import EFDD, FDD, FSDD, SSI  # noqa: E402
from pyoma2.setup import SingleSetup  # noqa: E402

HERE = Path(__file__).resolve().parent
RECORD = HERE / "Palisaden_dataset.npy"
OUT = HERE / "pyoma2_reference.json"
FS_HZ = 100.0
SEL_FREQ_HZ = [1.88, 2.42, 2.68]
CHANNELS = ["ch1", "ch2", "ch3", "ch4", "ch5", "ch6"]


def _complex(a) -> dict:
    a = np.asarray(a)
    return {"re": np.real(a).tolist(), "im": np.imag(a).tolist()}


def _mpc(phi: np.ndarray) -> float:
    """Modal phase collinearity (Pappa et al.) of one complex shape: 1 for a real (normal) mode."""
    sxx, syy, sxy = phi.real @ phi.real, phi.imag @ phi.imag, phi.real @ phi.imag
    return float(((sxx - syy) ** 2 + 4 * sxy**2) / (sxx + syy) ** 2)


def _mac(a: np.ndarray, b: np.ndarray) -> float:
    return float(abs(np.vdot(a, b)) ** 2 / (np.vdot(a, a).real * np.vdot(b, b).real))


def _setup() -> tuple[SingleSetup, float]:
    t0 = time.perf_counter()
    data = np.load(RECORD)
    ss = SingleSetup(data, fs=FS_HZ)
    ss.filter_data(Wn=0.1, order=8, btype="highpass")
    ss.decimate_data(q=5)
    return ss, time.perf_counter() - t0


def _modes(result, with_std: bool) -> dict:
    phi = np.asarray(result.Phi)  # channels x modes
    out = {"frequency_hz": np.asarray(result.Fn).tolist(),
           "damping_ratio": None if getattr(result, "Xi", None) is None else np.asarray(result.Xi).tolist(),
           "shape": _complex(phi.T),  # modes x channels
           "mpc": [_mpc(phi[:, k]) for k in range(phi.shape[1])]}
    if with_std:
        out["frequency_std_hz"] = np.asarray(result.Fn_std).tolist()
        out["damping_std"] = np.asarray(result.Xi_std).tolist()
        out["order"] = np.asarray(result.order_out).tolist()
    return out


def main() -> None:
    ss, t_setup = _setup()
    print(f"load + high-pass + decimate: {t_setup:.2f} s")
    timings = {"load_filter_decimate_s": t_setup}
    ssi = SSI(name="SSIcov", method="cov", br=30, ordmax=30, calc_unc=True)
    fsdd = FSDD(name="FSDD", nxseg=2048, method_SD="per", pov=0.5)
    efdd = EFDD(name="EFDD", nxseg=2048, method_SD="per", pov=0.5)
    fdd = FDD(name="FDD", nxseg=2048, method_SD="per", pov=0.5)
    ss.add_algorithms(ssi, fsdd, efdd, fdd)
    results = {}
    for name, kw, with_std in (("SSIcov", {"order_in": 20}, True), ("FSDD", {"MAClim": 0.95}, False),
                               ("EFDD", {"MAClim": 0.95}, False), ("FDD", {}, False)):
        t = time.perf_counter()
        ss.run_by_name(name)
        ss.mpe(name, sel_freq=SEL_FREQ_HZ, **kw)
        timings[f"{name}_run_mpe_s"] = time.perf_counter() - t
        results[name] = _modes(ss[name].result, with_std)
        print(name, np.round(results[name]["frequency_hz"], 4), results[name]["damping_ratio"] and
              np.round(results[name]["damping_ratio"], 4), f"{timings[f'{name}_run_mpe_s']:.2f} s")
    # SSI-cov alone, without the bootstrap uncertainty: the estimator's own cost, for timing; its
    # modes must be the ones above (the uncertainty does not change the point estimates)
    plain = SSI(name="SSIcov-plain", method="cov", br=30, ordmax=30, calc_unc=False)
    ss.add_algorithms(plain)
    t = time.perf_counter()
    ss.run_by_name(plain.name)
    ss.mpe(plain.name, sel_freq=SEL_FREQ_HZ, order_in=20)
    timings["SSIcov_no_uncertainty_run_mpe_s"] = time.perf_counter() - t
    assert np.allclose(plain.result.Fn, results["SSIcov"]["frequency_hz"], rtol=1e-9)
    print("SSIcov without uncertainty", f"{timings['SSIcov_no_uncertainty_run_mpe_s']:.2f} s")
    phis = {n: np.array(r["shape"]["re"]) + 1j * np.array(r["shape"]["im"]) for n, r in results.items()}
    mac_fsdd = [_mac(phis["SSIcov"][k], phis["FSDD"][k]) for k in range(len(SEL_FREQ_HZ))]
    print("MAC SSIcov-FSDD per mode:", np.round(mac_fsdd, 5))
    doc = {
        "description": "pyOMA2's modes of the Palisaden building record (Palisaden_dataset.npy), made by "
                       "make_pyoma2_reference.py; see README.md",
        "record": {"file": RECORD.name, "sampling_rate_hz": FS_HZ, "samples": 540000,
                   "channels": CHANNELS, "units": "m/s^2 (assumed; the source does not state them)"},
        "shape_convention": "shape[mode][channel], complex as pyOMA2 returns it (re, im), channels in the "
                            "record's column order ch1..ch6, in the data's units relative to each other "
                            "(no per-channel scaling; pyOMA2 normalises each mode to a largest entry of 1)",
        "settings": {"preprocessing": "filter_data(Wn=0.1, order=8, btype='highpass'); decimate_data(q=5): "
                                      "20 Hz, 108000 samples",
                     "SSIcov": "SSI(method='cov', br=30, ordmax=30, calc_unc=True); "
                               "mpe(sel_freq=[1.88, 2.42, 2.68], order_in=20)",
                     "FSDD": "FSDD(nxseg=2048, method_SD='per', pov=0.5); mpe(sel_freq=[1.88, 2.42, 2.68], "
                             "MAClim=0.95)",
                     "EFDD": "EFDD(nxseg=2048, method_SD='per', pov=0.5); mpe(sel_freq=[1.88, 2.42, 2.68], "
                             "MAClim=0.95)",
                     "FDD": "FDD(nxseg=2048, method_SD='per', pov=0.5); mpe(sel_freq=[1.88, 2.42, 2.68]) "
                            "(peak picking: no damping)"},
        "published_hz": {"SSIcov": [1.88205042, 2.4211625, 2.68851009],
                         "FSDD": [1.8787832, 2.42254302, 2.67381079]},
        "mac_ssicov_fsdd": mac_fsdd,
        "versions": {"pyOMA-2": version("pyOMA-2"), "numpy": np.__version__, "scipy": version("scipy"),
                     "python": platform.python_version()},
        "modes": results,
    }
    OUT.write_text(json.dumps(doc, indent=1) + "\n")
    print("wrote", OUT.name, {k: round(v, 2) for k, v in timings.items()})


if __name__ == "__main__":
    main()
