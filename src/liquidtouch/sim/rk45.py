"""Dormand–Prince RK45 with dense output at given times: SciPy's ``solve_ivp`` RK45, bit for bit.

Why a copy: ``scipy.integrate`` costs ~0.5 s to import (its quadrature and BVP
modules pull in ``scipy.special`` and ``scipy.linalg``), which every ``simulate``
command paid before its first trial, for one explicit Runge–Kutta method. This
module repeats the arithmetic of SciPy 1.17's ``RK45`` (``scipy/integrate/_ivp/rk.py``,
``common.py``, ``ivp.py``; BSD-3-Clause, © the SciPy developers) operation for
operation — the same tableau, initial-step rule, error norm, step-size control
and quartic interpolant at the requested times — so the simulated trajectories,
and with them every rendered frame, are unchanged (``tests/test_sim_physics.py``
compares the two with ``np.array_equal``). Forward integration of a real,
non-stiff system only: no events, no complex states, no vectorised right-hand side.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

SAFETY = 0.9  # step-size factors of SciPy's Runge–Kutta solvers
MIN_FACTOR = 0.2
MAX_FACTOR = 10.0
ERROR_EXPONENT = -1 / (4 + 1)  # the embedded error estimate is of order 4
C = np.array([0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1])
A = np.array(
    [
        [0, 0, 0, 0, 0],
        [1 / 5, 0, 0, 0, 0],
        [3 / 40, 9 / 40, 0, 0, 0],
        [44 / 45, -56 / 15, 32 / 9, 0, 0],
        [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0],
        [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656],
    ]
)
B = np.array([35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84])
E = np.array([-71 / 57600, 0, 71 / 16695, -71 / 1920, 17253 / 339200, -22 / 525, 1 / 40])
P = np.array(  # the dense output's quartic (Shampine's optimum c_6)
    [
        [1, -8048581381 / 2820520608, 8663915743 / 2820520608, -12715105075 / 11282082432],
        [0, 0, 0, 0],
        [
            0,
            131558114200 / 32700410799,
            -68118460800 / 10900136933,
            87487479700 / 32700410799,
        ],
        [
            0,
            -1754552775 / 470086768,
            14199869525 / 1410260304,
            -10690763975 / 1880347072,
        ],
        [
            0,
            127303824393 / 49829197408,
            -318862633887 / 49829197408,
            701980252875 / 199316789632,
        ],
        [0, -282668133 / 205662961, 2019193451 / 616988883, -1453857185 / 822651844],
        [0, 40617522 / 29380423, -110615467 / 29380423, 69997945 / 29380423],
    ]
)


def _rms(x: np.ndarray) -> float:
    return np.linalg.norm(x) / x.size**0.5


def _initial_step(fun, t0, y0, t_bound, max_step, f0, rtol, atol) -> float:
    """SciPy's ``select_initial_step`` (Hairer, Nørsett, Wanner, Sec. II.4), forward in time."""
    interval_length = abs(t_bound - t0)
    if interval_length == 0.0:
        return 0.0
    scale = atol + np.abs(y0) * rtol
    d0 = _rms(y0 / scale)
    d1 = _rms(f0 / scale)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    h0 = min(h0, interval_length)
    f1 = fun(t0 + h0, y0 + h0 * f0)
    d2 = _rms((f1 - f0) / scale) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** -ERROR_EXPONENT
    return min(100 * h0, h1, interval_length, max_step)


def solve_rk45(
    rhs: Callable[[float, np.ndarray], object],
    t_eval_s: np.ndarray,
    y0: np.ndarray,
    *,
    rtol: float,
    atol: float,
    max_step_s: float,
) -> np.ndarray:
    """Integrate ``y' = rhs(t, y)`` over ``t_eval_s`` [s]; return the states at those times.

    Returns ``(n_states, len(t_eval_s))``, equal to ``solve_ivp(rhs, (t0, t1), y0,
    t_eval=t_eval_s, method="RK45", rtol=rtol, atol=atol, max_step=max_step_s).y``.
    ``t_eval_s`` [s] must increase; ``rhs`` returns the derivative as a sequence of floats.
    Raises ``RuntimeError`` if the step size underflows.
    """

    def fun(t, y):
        return np.asarray(rhs(t, y), dtype=float)

    t_eval = np.asarray(t_eval_s, dtype=float)
    t, t_bound = float(t_eval[0]), float(t_eval[-1])
    y = np.asarray(y0).astype(float, copy=False)
    if t == t_bound:  # nothing to integrate: the initial state at every requested time
        return np.repeat(y[:, None], len(t_eval), axis=1)
    atol_arr = np.asarray(atol)
    f = fun(t, y)
    h_abs = _initial_step(fun, t, y, t_bound, max_step_s, f, rtol, atol_arr)
    K = np.empty((len(B) + 1, y.size), dtype=float)
    out: list[np.ndarray] = []
    i_eval = 0
    while t != t_bound:
        min_step = 10 * np.abs(np.nextafter(t, np.inf) - t)
        h_abs = max_step_s if h_abs > max_step_s else min_step if h_abs < min_step else h_abs
        rejected = False
        while True:  # one accepted step
            if h_abs < min_step:
                raise RuntimeError("slosh integration failed: the step size fell below its minimum")
            t_new = t + h_abs
            if t_new > t_bound:
                t_new = t_bound
            h = t_new - t
            h_abs = np.abs(h)
            K[0] = f
            for s, (a, c) in enumerate(zip(A[1:], C[1:], strict=True), start=1):
                K[s] = fun(t + c * h, y + np.dot(K[:s].T, a[:s]) * h)
            y_new = y + h * np.dot(K[:-1].T, B)
            f_new = fun(t + h, y_new)
            K[-1] = f_new
            scale = atol_arr + np.maximum(np.abs(y), np.abs(y_new)) * rtol
            error_norm = _rms(np.dot(K.T, E) * h / scale)
            if error_norm < 1:
                factor = (
                    MAX_FACTOR
                    if error_norm == 0
                    else min(MAX_FACTOR, SAFETY * error_norm**ERROR_EXPONENT)
                )
                h_abs *= min(1, factor) if rejected else factor
                break
            h_abs *= max(MIN_FACTOR, SAFETY * error_norm**ERROR_EXPONENT)
            rejected = True
        i_new = np.searchsorted(t_eval, t_new, side="right")
        if i_new > i_eval:  # the requested times in (t, t_new], from the step's interpolant
            x = (t_eval[i_eval:i_new] - t) / h
            powers = np.cumprod(np.tile(x, (P.shape[1], 1)), axis=0)
            states = h * np.dot(K.T.dot(P), powers)
            states += y[:, None]
            out.append(states)
            i_eval = i_new
        t, y, f = t_new, y_new, f_new
    return np.hstack(out)
