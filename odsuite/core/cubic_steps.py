"""The time loop of the nonlinear simulation (cubic springs), compiled by numba.

Its arithmetic is a few products of matrices of a dozen rows per step; numpy would pay a Python
call per product and step (about 45 us a step on five records at once), compiled code pays none
(about 1 us). Kept in its own module so that numba loads only when a model has cubic springs."""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, nogil=True)
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
    for r in range(n_records):
        xg[:] = 0.0
        states[0, r, :] = 0.0
        for k in range(n_steps):
            for i in range(n_state):
                acc = linear[r, k, i]
                for j in range(n_state + m):
                    acc += xg[j] * step_t[j, i]
                x[i] = acc
            for i in range(m):
                acc = linear_deflection[r, k, i]
                for j in range(n_state + m):
                    acc += xg[j] * deflect_t[j, i]
                d_base[i] = acc
            # predictor: the start's cubic force held over the step
            for i in range(m):
                acc = d_base[i]
                for j in range(m):
                    acc -= xg[n_state + j] * end_deflection_t[j, i]
                d[i] = acc
            # corrector: the cubic force at the predicted end
            for j in range(m):
                g[j] = c[j] * d[j] * d[j] * d[j]
            for i in range(m):
                acc = d_base[i]
                for j in range(m):
                    acc -= g[j] * end_deflection_t[j, i]
                d[i] = acc
            for j in range(m):
                g[j] = c[j] * d[j] * d[j] * d[j]
            for i in range(n_state):
                acc = x[i]
                for j in range(m):
                    acc -= g[j] * end_pull_t[j, i]
                x[i] = acc
            for i in range(m):
                acc = d_base[i]
                for j in range(m):
                    acc -= g[j] * end_deflection_t[j, i]
                xg[n_state + i] = c[i] * acc * acc * acc
            for i in range(n_state):
                xg[i] = x[i]
                states[k + 1, r, i] = x[i]
