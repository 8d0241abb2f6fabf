"""The compiled recursions against scipy.signal's lfilter and sosfilt: equal to the bit (the same
operations in the same order), so predictions and every number fitted from them are unchanged."""

from __future__ import annotations

import numpy as np
import scipy.signal

from odsuite.domain.recursions import (chain_columns, chain_columns_wide, first_order_rows, second_order_rows,
                                        sections_in_place)


def test_second_order_rows_are_lfilter_to_the_bit():
    rng = np.random.default_rng(1)
    u = rng.standard_normal((2, 4001))
    p = 0.999 * np.exp(1j * rng.uniform(0.01, 3.0, 5))  # lightly damped poles, as a structure's modes
    den = np.array([[1.0, -2 * q.real, abs(q) ** 2] for q in np.r_[p, p]])
    num = rng.standard_normal((10, 3))
    zi = rng.standard_normal((10, 2))
    source = np.array([0, 1] * 5)
    ref = np.array([scipy.signal.lfilter(num[r], den[r], u[source[r]], zi=zi[r])[0] for r in range(10)])
    for rows in (10, 9):  # rows run in pairs: an odd one left over too
        out = np.empty((rows, u.shape[1]))
        second_order_rows(num[:rows], den[:rows], zi[:rows], source[:rows], u, out)
        assert np.array_equal(out, ref[:rows])


def test_first_order_rows_are_complex_lfilter_to_the_bit():
    rng = np.random.default_rng(4)
    u = rng.standard_normal((2, 3001))
    pole = 0.999 * np.exp(1j * rng.uniform(0.01, 3.0, 6))
    num = rng.standard_normal((6, 2)) + 1j * rng.standard_normal((6, 2))
    zi = rng.standard_normal(6) + 1j * rng.standard_normal(6)
    source = np.array([0, 1] * 3)
    for every in (1, 2, 3):
        ref = np.array([scipy.signal.lfilter(num[r], [1.0, -pole[r]], u[source[r]], zi=[zi[r]])[0][::every]
                        for r in range(6)])
        out = np.empty(ref.shape, complex)
        first_order_rows(num, pole, zi, source, u, every, out)
        assert np.array_equal(out, ref)


def test_sections_in_place_are_sosfilt_to_the_bit():
    rng = np.random.default_rng(2)
    x = rng.standard_normal((3000, 4))
    for sos in (scipy.signal.butter(8, 0.05, btype="high", output="sos"),
                scipy.signal.cheby1(5, 1.0, [0.1, 0.3], btype="band", output="sos")):
        y = x.copy()
        sections_in_place(sos, y)
        assert np.array_equal(y, scipy.signal.sosfilt(sos, x, axis=0))


def test_a_chain_operator_in_one_pass_is_its_steps_to_the_bit():
    from odsuite.analysis.prediction import StageOperator

    rng = np.random.default_rng(3)
    x = rng.standard_normal((2000, 6)) + 0.3
    sos = [scipy.signal.butter(4, 0.02, btype="high", output="sos"), scipy.signal.butter(6, 0.4, output="sos")]
    for x in (x, np.asfortranarray(x)):  # a simulation's transposed output too
        for factor, offset in ((1.0, (0, 300)), (1e6, None)):
            op = StageOperator((1, 4, 5), factor, offset, tuple((s, False) for s in sos))
            out = np.full_like(x, np.nan)
            op.apply_into(x, out)
            # the steps as StageOperator.apply took them with scipy's sosfilt
            cols = x[:, [1, 4, 5]]
            y = cols * factor if factor != 1.0 else cols.copy()
            if offset is not None:
                y -= y[:300].mean(axis=0)
            for s in sos:
                y = scipy.signal.sosfilt(s, y, axis=0)
            assert np.array_equal(out[:, [1, 4, 5]], y)
            assert np.isnan(out[:, [0, 2, 3]]).all()  # other columns untouched


def test_wide_chain_is_chain_columns_to_the_bit():
    rng = np.random.default_rng(7)
    sos = scipy.signal.butter(4, 0.3, output="sos")
    for m, order in ((31, "C"), (12, "F"), (1, "C")):
        x = np.asarray(rng.standard_normal((1500, m + 2)), order=order)
        cols = np.arange(1, m + 1)
        offsets = rng.standard_normal(m)
        ref, out = np.zeros_like(x), np.zeros_like(x)
        chain_columns(x, cols, 1.5, offsets, sos, ref)
        chain_columns_wide(x, cols, 1.5, offsets, sos, out)
        assert np.array_equal(out, ref)
        inplace = x.copy(order=order)
        sections_in_place(sos, inplace[:, 1:m + 1], wide=True)
        assert np.array_equal(inplace[:, 1:m + 1], scipy.signal.sosfilt(sos, x[:, 1:m + 1], axis=0))
