"""pyOMA2's word on the Palisaden record's poles above the three published modes (5-8 Hz), as a
peer reference for odsuite's fourth and fifth poles (about 5.90 and 6.68 Hz).

Run in an environment with pyOMA2 (PyPI package ``pyOMA-2``; not an odsuite dependency)::

    python -m venv peer && peer/bin/pip install pyOMA-2==1.4.3
    peer/bin/python tests/data/real/palisaden_building/make_pyoma2_upper_modes.py

Settings as ``make_pyoma2_reference.py`` (pyOMA2's "Example2 - Real dataset"): high-pass
Butterworth 0.1 Hz of order 8, decimation by 5 (20 Hz, so the band is 0-10 Hz and holds 5-8 Hz);
SSI-cov with 30 block rows, orders 0-30, pyOMA2's default stability criteria (frequency 5 %,
damping 10 %, 1 - MAC 5 % against the previous order) and its bootstrap uncertainty; FDD, EFDD and
FSDD on Welch periodograms of 2048 samples with 50 % overlap, MAC limit 0.95. It prints, per order,
the poles in 5-8 Hz with pyOMA2's stability label, and the modes extracted at 1.88, 2.42, 2.68,
5.90 and 6.68 Hz: SSI-cov at order 30 (the highest, where pyOMA2 labels every one of them stable),
the FDD family at its peaks. The constants in tests/cli/test_cli_modes.py were copied from its
output; README.md records them.
"""

from __future__ import annotations

import logging
from importlib.metadata import version
from pathlib import Path

import numpy as np

logging.disable(logging.WARNING)

from pyoma2.algorithms import EFDD, FDD, FSDD, SSI  # noqa: E402
from pyoma2.setup import SingleSetup  # noqa: E402

HERE = Path(__file__).resolve().parent
SEL_FREQ_HZ = [1.88, 2.42, 2.68, 5.90, 6.68]
ORDER = 30
BAND_HZ = (5.0, 8.0)


def main() -> None:
    ss = SingleSetup(np.load(HERE / "Palisaden_dataset.npy"), fs=100.0)
    ss.filter_data(Wn=0.1, order=8, btype="highpass")
    ss.decimate_data(q=5)
    ssi = SSI(name="SSIcov", method="cov", br=30, ordmax=ORDER, calc_unc=True)
    fdd_kw = dict(nxseg=2048, method_SD="per", pov=0.5)
    algs = [FDD(name="FDD", **fdd_kw), EFDD(name="EFDD", **fdd_kw), FSDD(name="FSDD", **fdd_kw)]
    ss.add_algorithms(ssi, *algs)
    ss.run_by_name("SSIcov")
    r = ssi.result
    print(f"pyOMA-2 {version('pyOMA-2')}, numpy {np.__version__}")
    print(f"SSI-cov poles in {BAND_HZ[0]:g}-{BAND_HZ[1]:g} Hz per order (* stable by pyOMA2's criteria):")
    for o in range(r.Fn_poles.shape[1]):
        inside = np.flatnonzero((r.Fn_poles[:, o] > BAND_HZ[0]) & (r.Fn_poles[:, o] < BAND_HZ[1]))
        if inside.size:
            print(f"  order {o:2d}: " + ", ".join(
                f"{r.Fn_poles[i, o]:.3f} Hz {100 * r.Xi_poles[i, o]:.2f} %{'*' if r.Lab[i, o] == 1 else ''}"
                for i in inside[np.argsort(r.Fn_poles[inside, o])]))
    ss.mpe("SSIcov", sel_freq=SEL_FREQ_HZ, order_in=ORDER)
    m = ssi.result
    print(f"SSI-cov modes at order {ORDER}:")
    for k in range(len(SEL_FREQ_HZ)):
        phi = np.asarray(m.Phi)[:, k]
        print(f"  {m.Fn[k]:.5f} +- {m.Fn_std[k]:.5f} Hz, damping {m.Xi[k]:.5f} +- {m.Xi_std[k]:.5f}, shape "
              + "[" + ", ".join(f"{v.real:.4f}{v.imag:+.4f}j" for v in phi) + "]")
    for alg in algs:
        ss.run_by_name(alg.name)
        ss.mpe(alg.name, sel_freq=SEL_FREQ_HZ, **({} if alg.name == "FDD" else {"MAClim": 0.95}))
        res = alg.result
        xi = getattr(res, "Xi", None)
        print(f"{alg.name}: " + ", ".join(
            f"{f:.5f} Hz" + ("" if xi is None else f" {100 * xi[k]:.2f} %") for k, f in enumerate(res.Fn)))
        if alg.name == "EFDD":
            print("  EFDD shapes: " + "; ".join(
                "[" + ", ".join(f"{v.real:.4f}{v.imag:+.4f}j" for v in np.asarray(res.Phi)[:, k]) + "]"
                for k in range(len(SEL_FREQ_HZ))))


if __name__ == "__main__":
    main()
