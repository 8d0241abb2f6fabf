"""Regenerate pyoma2_multisetup_reference.json: pyOMA2's multi-setup PoSER on the Palisaden record
split into three setups, a peer reference for odsuite's merging (tests/core/test_multisetup.py).

Run in an environment with pyOMA2 (PyPI package ``pyOMA-2``; not an odsuite dependency)::

    python -m venv peer && peer/bin/pip install pyOMA-2==1.4.3
    peer/bin/python tests/data/real/palisaden_building/make_pyoma2_multisetup_reference.py

The split is the test's: the record's three 30-min thirds, setup a = channels ch2, ch3, ch1 at the
recorded level, b = ch2, ch3, ch4 times 3.7, c = ch2, ch3, ch5, ch6 times 0.5; ch2 and ch3 are the
reference channels (the first two columns of every setup). Each setup is analysed with the settings of
pyoma2_reference.json (pyOMA2's documented example): high-pass Butterworth 0.1 Hz of order 8,
decimation by 5, SSI-cov with 30 block rows, orders up to 30, modes at order 20 nearest 1.88, 2.42
and 2.68 Hz; then MultiSetup_PoSER(ref_ind=[[0, 1]] * 3).merge_results() with its defaults.
"""

from __future__ import annotations

import json
import logging
import platform
from importlib.metadata import version
from pathlib import Path

import numpy as np

logging.disable(logging.WARNING)

from pyoma2.algorithms import SSI  # noqa: E402
from pyoma2.setup import MultiSetup_PoSER, SingleSetup  # noqa: E402

HERE = Path(__file__).resolve().parent
RECORD = HERE / "Palisaden_dataset.npy"
OUT = HERE / "pyoma2_multisetup_reference.json"
FS_HZ = 100.0
SEL_FREQ_HZ = [1.88, 2.42, 2.68]
SETUPS = {"a": ([1, 2, 0], 1.0), "b": ([1, 2, 3], 3.7), "c": ([1, 2, 4, 5], 0.5)}  # 0-based columns, level


def main() -> None:
    y = np.load(RECORD)
    n = y.shape[0] // len(SETUPS)
    singles, per_setup = [], {}
    for k, (name, (cols, level)) in enumerate(SETUPS.items()):
        ss = SingleSetup(level * y[k * n:(k + 1) * n, cols], fs=FS_HZ)
        ss.filter_data(Wn=0.1, order=8, btype="highpass")
        ss.decimate_data(q=5)
        ssi = SSI(name="SSIcov", method="cov", br=30, ordmax=30, calc_unc=False)
        ss.add_algorithms(ssi)
        ss.run_all()
        ss.mpe("SSIcov", sel_freq=SEL_FREQ_HZ, order_in=20)
        per_setup[name] = {"frequency_hz": np.asarray(ssi.result.Fn).tolist(),
                           "damping_ratio": np.asarray(ssi.result.Xi).tolist()}
        print(name, np.round(ssi.result.Fn, 4))
        singles.append(ss)
    ms = MultiSetup_PoSER(ref_ind=[[0, 1]] * len(SETUPS), single_setups=singles, names=["SSIcov"])
    res = ms.merge_results()["SSIcov"]
    channels = ["ch2", "ch3"] + [f"ch{c + 1}" for cols, _ in SETUPS.values() for c in cols[2:]]
    phi = np.asarray(res.Phi)  # channels x modes
    doc = {
        "description": "pyOMA2's MultiSetup_PoSER of the Palisaden record split into three setups, made by "
                       "make_pyoma2_multisetup_reference.py; see README.md",
        "setups": {s: {"channels": [f"ch{c + 1}" for c in cols], "level": level,
                       "samples": [k * n, (k + 1) * n]}
                   for k, (s, (cols, level)) in enumerate(SETUPS.items())},
        "references": ["ch2", "ch3"],
        "channels": channels,
        "settings": "per setup: filter_data(Wn=0.1, order=8, btype='highpass'); decimate_data(q=5); "
                    "SSI(method='cov', br=30, ordmax=30); mpe(sel_freq=[1.88, 2.42, 2.68], order_in=20); "
                    "MultiSetup_PoSER(ref_ind=[[0, 1]] * 3).merge_results()",
        "frequency_hz": np.asarray(res.Fn).tolist(), "frequency_std_hz": np.asarray(res.Fn_std).tolist(),
        "damping_ratio": np.asarray(res.Xi).tolist(), "damping_std": np.asarray(res.Xi_std).tolist(),
        "shape": {"re": np.real(phi.T).tolist(), "im": np.imag(phi.T).tolist()},  # [mode][channel]
        "per_setup": per_setup,
        "versions": {"pyOMA-2": version("pyOMA-2"), "numpy": np.__version__, "scipy": version("scipy"),
                     "python": platform.python_version()},
    }
    OUT.write_text(json.dumps(doc, indent=1) + "\n")
    print("merged", np.round(res.Fn, 5), "std", np.round(res.Fn_std, 5), "wrote", OUT.name)


if __name__ == "__main__":
    main()
