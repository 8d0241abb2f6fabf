"""The time loop of the nonlinear simulation (cubic springs), compiled by numba.

Its arithmetic is a few products of matrices of a dozen rows per step; numpy would pay a Python
call per product and step (about 45 us a step on five records at once), compiled code pays none.
Its own module: a linear model's simulation loads only the recursions'."""

from __future__ import annotations

import numpy as np

from odsuite.domain.compiled import compiled


@compiled(nogil=True, inline="always")
def _affine(base, sign, g, M, acc, out):
    """out[r] = base[r] + sign g[r] @ M for every record r (a row of each array; out may be
    base). Row by row of ``M`` into the scratch ``acc``, every record at each row: the records'
    sums are independent and overlap in the processor where one record's would wait on its own
    last addition; each sum runs in the order of element by element (vectorised along M's rows)."""
    records, n = out.shape
    for r in range(records):
        for i in range(n):
            acc[r, i] = 0.0
    for j in range(M.shape[0]):
        for r in range(records):
            gj = g[r, j]
            for i in range(n):
                acc[r, i] += gj * M[j, i]
    for r in range(records):
        for i in range(n):
            out[r, i] = base[r, i] + sign * acc[r, i]


@compiled(nogil=True, inline="always")
def _cubed(c, d, out):
    for r in range(d.shape[0]):
        for j in range(d.shape[1]):
            out[r, j] = c[j] * d[r, j] * d[r, j] * d[r, j]


@compiled(nogil=True)
def cubic_steps(step_t, inputs, end_pull_t, end_deflection_t, c, states):
    """Advance every record through its steps; ``states[k, r]`` is record r's state after step k.

    A step: the state and the cubic force at its start map linearly to the state and the element
    deflections at its end (``step_t``: the state's columns, then the deflections'; ``inputs``:
    the inputs' part of both); the cubic force at the end comes from a predictor (the start's force
    held) and one corrector (the force at the predicted deflection), and pulls the state by
    ``end_pull_t``. All records advance together, a step at a time (each record's arithmetic
    that of its own loop)."""
    n_records, n_steps = inputs.shape[0], inputs.shape[1]
    n_state, m = states.shape[2], c.shape[0]
    xg = np.zeros((n_records, n_state + m))  # state and cubic force at a step's start
    xd = np.empty((n_records, n_state + m))  # state and deflections at its end, the force's pull left out
    x = xd[:, :n_state]
    d_base = xd[:, n_state:]
    d = np.empty((n_records, m))
    g = np.empty((n_records, m))
    acc = np.empty((n_records, n_state + m))
    states[0] = 0.0
    for k in range(n_steps):
        _affine(inputs[:, k], 1.0, xg, step_t, acc, xd)
        _affine(d_base, -1.0, xg[:, n_state:], end_deflection_t, acc, d)  # predictor: the start's force held
        _cubed(c, d, g)
        _affine(d_base, -1.0, g, end_deflection_t, acc, d)  # corrector: the force at the predicted end
        _cubed(c, d, g)
        _affine(x, -1.0, g, end_pull_t, acc, x)
        _affine(d_base, -1.0, g, end_deflection_t, acc, d)
        _cubed(c, d, xg[:, n_state:])
        xg[:, :n_state] = x
        states[k + 1] = x
