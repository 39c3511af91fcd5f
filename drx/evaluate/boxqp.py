"""A small solver for box-constrained convex quadratic programs.

Solves ``min f(x) = 1/2 x'Hx + g'x  subject to  lo <= x <= hi`` for a symmetric
positive definite ``H`` of a few hundred to a couple of thousand variables,
with NumPy only (drx does not depend on SciPy).

Method: Bertsekas' **projected Newton** method (Bertsekas, "Projected Newton
methods for optimization problems with simple constraints", SIAM J. Control
Optim. 20(2), 1982). At each iteration:

1. The *binding* set holds the variables on (or within ``eps`` of) a bound
   whose gradient pushes them further out; the others are *free*.
2. The step is the Newton step on the free variables
   (``d_F = H_FF^-1 grad_F``, one dense solve) and a diagonally scaled
   gradient step on the binding ones.
3. The new point is ``P(x - t d)``, the projection onto the box, with ``t``
   halved from 1 until Armijo's sufficient-decrease test passes.

The method converges from any start, however badly conditioned ``H`` is (the
curvature objectives of :mod:`drx.evaluate.racing_line` span ten orders of
magnitude, which defeats first-order methods such as ADMM or projected
gradient). Once the active set is found, a unit step lands on the exact
minimiser, so it stops after a handful to a few dozen iterations. It stops
when the KKT conditions hold: the gradient vanishes on free variables and
points outwards on variables at a bound.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

ARMIJO = 1e-4  # sufficient-decrease constant


@dataclass(frozen=True)
class BoxQPResult:
    """The solution of a box QP.

    :param x: the minimiser, inside ``[lo, hi]``.
    :param converged: whether the KKT conditions were met within the tolerance.
    :param iterations: projected-Newton iterations used.
    """

    x: np.ndarray
    converged: bool
    iterations: int


def solve_box_qp(
    h: np.ndarray,
    g: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    *,
    max_iterations: int = 200,
    tol: float = 1e-9,
) -> BoxQPResult:
    """Minimise ``1/2 x'Hx + g'x`` over the box ``lo <= x <= hi``.

    :param h: ``(n, n)`` symmetric positive definite matrix (add a small ridge to a
        semi-definite one).
    :param g: ``(n,)`` linear term.
    :param lo: ``(n,)`` finite lower bounds.
    :param hi: ``(n,)`` finite upper bounds, ``hi >= lo``.
    :param max_iterations: the most projected-Newton iterations.
    :param tol: KKT tolerance, relative to the box's size.
    :return: the minimiser and how the solve went.
    """
    n = len(g)
    if h.shape != (n, n) or lo.shape != (n,) or hi.shape != (n,):
        raise ValueError("solve_box_qp: H must be (n, n) and g, lo, hi (n,) arrays.")
    if np.any(lo > hi):
        raise ValueError("solve_box_qp: some lower bound exceeds its upper bound; the box is empty.")
    diag = np.maximum(np.diag(h), 1e-300)
    x = _initial_point(h, g, lo, hi)
    grad = h @ x + g
    scale = max(float(np.max(hi - lo, initial=0.0)), float(np.max(np.abs(x), initial=0.0)), 1e-12)
    for k in range(1, max_iterations + 1):
        if _kkt_error(x, grad / diag, lo, hi) <= tol * scale:
            return BoxQPResult(x=x, converged=True, iterations=k - 1)
        # Bertsekas' epsilon: shrinks with the distance to optimality (gradient scaled by the diagonal).
        eps = min(
            float(np.min(hi - lo, initial=np.inf)) / 2.0,
            float(np.linalg.norm(x - _proj(x - grad / diag, lo, hi))),
        )
        binding = ((x <= lo + eps) & (grad > 0)) | ((x >= hi - eps) & (grad < 0))
        free = ~binding
        d = grad / diag
        if free.any():
            d[free] = np.linalg.solve(h[np.ix_(free, free)], grad[free])
        fx = 0.5 * x @ (grad + g)
        t = 1.0
        while True:
            x_new = _proj(x - t * d, lo, hi)
            f_new = 0.5 * x_new @ (h @ x_new) + g @ x_new
            decrease = t * float(grad[free] @ d[free]) + float(grad[binding] @ (x - x_new)[binding])
            if fx - f_new >= ARMIJO * decrease or t < 1e-12:
                break
            t *= 0.5
        x = x_new
        grad = h @ x + g
    return BoxQPResult(
        x=x, converged=_kkt_error(x, grad / diag, lo, hi) <= tol * scale, iterations=max_iterations
    )


def _initial_point(h: np.ndarray, g: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """The unconstrained minimiser, projected onto the box."""
    return _proj(np.linalg.solve(h, -g), lo, hi)


def _proj(x: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    return np.minimum(np.maximum(x, lo), hi)


def _kkt_error(x: np.ndarray, grad: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> float:
    """Largest violation of the KKT conditions, ``|x - P(x - grad)|``, for a diagonally scaled gradient."""
    return float(np.max(np.abs(x - _proj(x - grad, lo, hi)), initial=0.0))
