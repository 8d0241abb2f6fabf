"""Linear recursions over many signals in one compiled call (numba), with the arithmetic of
scipy.signal.lfilter (direct form II transposed) and scipy.signal.sosfilt operation for operation,
so their results are the same to the bit.

A model evaluation runs a second-order recursion per mode and part (real, imaginary) and a chain
of second-order sections per group of channels: tens of thousands of scipy calls per diagnosis,
whose argument checks and axis moves cost as much as the filtering on short records."""

from __future__ import annotations

import numpy as np

from odsuite.domain.compiled import compiled


@compiled(nogil=True, inline="always")
def _step(b0, b1, b2, a1, a2, xn, z0, z1):
    """One sample of lfilter's direct form II transposed (a0 = 1): output and new delays."""
    y = z0 + b0 * xn
    return y, z1 + xn * b1 - y * a1, xn * b2 - y * a2


@compiled(nogil=True)
def second_order_rows(num, den, zi, source, u, out):
    """Row r of ``out``: ``lfilter(num[r], den[r], u[source[r]], zi=zi[r])`` (``den[r, 0]`` = 1).
    Rows run two at a time: each recursion waits on its own last output, two keep the processor
    busy (each row's operations unchanged)."""
    n, rows = u.shape[1], num.shape[0]
    for r in range(0, rows, 2):
        s = min(r + 1, rows - 1)  # an odd last row runs beside itself
        b0, b1, b2, a1, a2 = num[r, 0], num[r, 1], num[r, 2], den[r, 1], den[r, 2]
        c0, c1, c2, e1, e2 = num[s, 0], num[s, 1], num[s, 2], den[s, 1], den[s, 2]
        z0, z1, w0, w1 = zi[r, 0], zi[r, 1], zi[s, 0], zi[s, 1]
        x, v = u[source[r]], u[source[s]]
        for k in range(n):
            out[r, k], z0, z1 = _step(b0, b1, b2, a1, a2, x[k], z0, z1)
            out[s, k], w0, w1 = _step(c0, c1, c2, e1, e2, v[k], w0, w1)


def sections_in_place(sos, x, wide: bool = False):
    """``x`` (samples x signals) through the second-order sections ``sos`` from rest, each column
    a signal, written back into ``x``: ``scipy.signal.sosfilt(sos, x, axis=0)`` (chain_columns on
    every column, unscaled: times 1 and less 0 are exact; ``wide``: chain_columns_wide, the same
    numbers, for many signals)."""
    m = x.shape[1]
    (chain_columns_wide if wide else chain_columns)(x, np.arange(m), 1.0, np.zeros(m), sos, x)


@compiled(nogil=True)
def chain_columns(x, cols, factor, offsets, sos, out):
    """Columns ``cols`` of ``x`` (samples x signals), times ``factor``, less ``offsets`` (one per
    column), through the sections ``sos`` from rest, into the same columns of ``out``: what
    ``y = x[:, cols] * factor; y -= offsets; out[:, cols] = sosfilt(sos, y, axis=0)`` gives,
    without the copies; ``out`` may be ``x`` (each sample is read before it is written)."""
    n, m, ns = x.shape[0], cols.shape[0], sos.shape[0]
    z = np.zeros((m, ns, 2))
    for k in range(n):
        for i in range(m):
            x_cur = x[k, cols[i]] * factor - offsets[i]
            for s in range(ns):
                x_new = sos[s, 0] * x_cur + z[i, s, 0]
                z[i, s, 0] = sos[s, 1] * x_cur - sos[s, 4] * x_new + z[i, s, 1]
                z[i, s, 1] = sos[s, 2] * x_cur - sos[s, 5] * x_new
                x_cur = x_new
            out[k, cols[i]] = x_cur


@compiled(nogil=True)
def first_order_rows(num, pole, zi, source, u, every, out):
    """Row r of ``out``: ``lfilter(num[r], [1, -pole[r]], u[source[r]], zi=[zi[r]])[::every]``
    (complex coefficients, a real input), in the real arithmetic lfilter's complex filter does
    (its products by the input's zero imaginary part and by a0 = 1 are exact and left out)."""
    n = u.shape[1]
    for r in range(num.shape[0]):
        b0r, b0i, b1r, b1i = num[r, 0].real, num[r, 0].imag, num[r, 1].real, num[r, 1].imag
        ar, ai = -pole[r].real, -pole[r].imag
        zr, zim = zi[r].real, zi[r].imag
        x = u[source[r]]
        for k in range(n):
            yr = zr + b0r * x[k]
            yi = zim + b0i * x[k]
            zr = b1r * x[k] - (ar * yr - ai * yi)
            zim = b1i * x[k] - (ai * yr + ar * yi)
            if k % every == 0:
                out[r, k // every] = complex(yr, yi)


@compiled(nogil=True)
def chain_columns_wide(x, cols, factor, offsets, sos, out):
    """chain_columns with its columns side by side: each section's step runs over every column
    at once (independent sums, which the processor overlaps; each column's operations and their
    order unchanged, so the same numbers). Faster where many signals share one chain (a
    linearised Jacobian's basis), no faster on a record's few channels."""
    n, m, ns = x.shape[0], cols.shape[0], sos.shape[0]
    z0 = np.zeros((ns, m))
    z1 = np.zeros((ns, m))
    cur = np.empty(m)
    for k in range(n):
        for i in range(m):
            cur[i] = x[k, cols[i]] * factor - offsets[i]
        for s in range(ns):
            b0, b1, b2, a1, a2 = sos[s, 0], sos[s, 1], sos[s, 2], sos[s, 4], sos[s, 5]
            w0, w1 = z0[s], z1[s]
            for i in range(m):
                x_cur = cur[i]
                x_new = b0 * x_cur + w0[i]
                w0[i] = b1 * x_cur - a1 * x_new + w1[i]
                w1[i] = b2 * x_cur - a2 * x_new
                cur[i] = x_new
        for i in range(m):
            out[k, cols[i]] = cur[i]
