"""The time loop of the nonlinear simulation (cubic springs), compiled by numba.

Its arithmetic is a few products of matrices of a dozen rows per step; numpy would pay a Python
call per product and step (about 45 us a step on five records at once), compiled code pays none
(about 1 us). Its own module: a linear model's simulation loads only the recursions'."""

from __future__ import annotations

import numpy as np

from odsuite.domain.compiled import compiled


@compiled(nogil=True, inline="always")
def _affine(base, sign, g, M, acc, out):
    """out = base + sign g @ M (a vector times a small matrix; out may be base). Row by row of
    ``M`` into the scratch ``acc``: the inner loop runs along M's rows (vectorised), each sum in
    the same order as element by element."""
    n = out.shape[0]
    for i in range(n):
        acc[i] = 0.0
    for j in range(g.shape[0]):
        gj = g[j]
        for i in range(n):
            acc[i] += gj * M[j, i]
    for i in range(n):
        out[i] = base[i] + sign * acc[i]


@compiled(nogil=True, inline="always")
def _cubed(c, d, out):
    for j in range(d.shape[0]):
        out[j] = c[j] * d[j] * d[j] * d[j]


@compiled(nogil=True)
def cubic_steps(step_t, deflect_t, linear, linear_deflection, end_pull_t, end_deflection_t, c, states):
    """Advance every record through its steps; ``states[k, r]`` is record r's state after step k.

    A step: the state and the cubic force at its start map linearly to the state and the element
    deflections at its end (``step_t``, ``deflect_t``, with the inputs' part ``linear`` /
    ``linear_deflection``); the cubic force at the end comes from a predictor (the start's force
    held) and one corrector (the force at the predicted deflection), and pulls the state by
    ``end_pull_t``."""
    n_records, n_steps = linear.shape[0], linear.shape[1]
    n_state, m = step_t.shape[1], c.shape[0]
    xg = np.zeros(n_state + m)
    x = np.empty(n_state)
    d_base = np.empty(m)
    d = np.empty(m)
    g = np.empty(m)
    acc = np.empty(max(n_state, m))
    for r in range(n_records):
        xg[:] = 0.0
        states[0, r, :] = 0.0
        for k in range(n_steps):
            _affine(linear[r, k], 1.0, xg, step_t, acc, x)
            _affine(linear_deflection[r, k], 1.0, xg, deflect_t, acc, d_base)
            _affine(d_base, -1.0, xg[n_state:], end_deflection_t, acc, d)  # predictor: the start's force held
            _cubed(c, d, g)
            _affine(d_base, -1.0, g, end_deflection_t, acc, d)  # corrector: the force at the predicted end
            _cubed(c, d, g)
            _affine(x, -1.0, g, end_pull_t, acc, x)
            _affine(d_base, -1.0, g, end_deflection_t, acc, d)
            _cubed(c, d, xg[n_state:])
            xg[:n_state] = x
            states[k + 1, r, :] = x
