"""The compiled recursions against scipy.signal's lfilter and sosfilt: equal to the bit (the same
operations in the same order), so predictions and every number fitted from them are unchanged."""

from __future__ import annotations

import numpy as np
import scipy.signal

from odsuite.domain.recursions import second_order_rows, sections_in_place


def test_second_order_rows_are_lfilter_to_the_bit():
    rng = np.random.default_rng(1)
    u = rng.standard_normal((2, 4001))
    p = 0.999 * np.exp(1j * rng.uniform(0.01, 3.0, 5))  # lightly damped poles, as a structure's modes
    den = np.array([[1.0, -2 * q.real, abs(q) ** 2] for q in np.r_[p, p]])
    num = rng.standard_normal((10, 3))
    zi = rng.standard_normal((10, 2))
    source = np.array([0, 1] * 5)
    ref = np.array([scipy.signal.lfilter(num[r], den[r], u[source[r]], zi=zi[r])[0] for r in range(10)])
    for every in (1, 2, 3):
        out = np.empty((10, len(range(0, u.shape[1], every))))
        second_order_rows(num, den, zi, source, u, every, out)
        assert np.array_equal(out, ref[:, ::every])


def test_sections_in_place_are_sosfilt_to_the_bit():
    rng = np.random.default_rng(2)
    x = rng.standard_normal((3000, 4))
    for sos in (scipy.signal.butter(8, 0.05, btype="high", output="sos"),
                scipy.signal.cheby1(5, 1.0, [0.1, 0.3], btype="band", output="sos")):
        y = x.copy()
        sections_in_place(sos, y)
        assert np.array_equal(y, scipy.signal.sosfilt(sos, x, axis=0))
