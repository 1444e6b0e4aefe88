"""IPOPT (through CasADi) for the direct transfers of :func:`lgvi.optimal.transfer` (``method="ipopt"``).

The NLP is the SciPy path's: the same variables, the same cost and cost gradient, the same terminal
constraints with their Jacobian from one reverse pass of the discrete adjoint. Each is wrapped as a
CasADi :class:`casadi.Callback` whose Jacobian is another callback (exact first derivatives from the
adjoint); IPOPT approximates the Hessian of the Lagrangian by limited-memory BFGS
(``hessian_approximation = limited-memory``), so it never needs second derivatives of the flow.
Memory and work per iteration grow linearly with the number of controls, where SLSQP's dense
quasi-Newton matrix and its QP grow quadratically and cubically: this is the solver for large ``N``.

CasADi is an optional dependency: ``pip install lgvi[ipopt]``.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

__all__ = ["require_casadi", "solve"]

INSTALL = "pip install lgvi[ipopt]"


def require_casadi():
    """The ``casadi`` module, or an ImportError that names the extra to install."""
    try:
        import casadi
    except ImportError as exc:
        raise ImportError(f"method='ipopt' needs CasADi (IPOPT ships with its wheel): {INSTALL}") from exc
    return casadi


def _callbacks(ca):
    """The two callback classes (defined on first use: ``casadi`` is optional)."""

    class Jacobian(ca.Callback):
        """``(x, f(x)) -> df/dx`` (dense ``m x n``), CasADi's calling convention for a Jacobian."""

        def __init__(self, name: str, n: int, m: int, jac: Callable[[np.ndarray], np.ndarray]):
            ca.Callback.__init__(self)
            self._n, self._m, self._jac = n, m, jac
            self.calls = 0
            self.construct(name, {})

        def get_n_in(self):
            return 2

        def get_n_out(self):
            return 1

        def get_sparsity_in(self, i):
            return ca.Sparsity.dense(self._n, 1) if i == 0 else ca.Sparsity.dense(self._m, 1)

        def get_sparsity_out(self, i):
            return ca.Sparsity.dense(self._m, self._n)

        def eval(self, arg):
            self.calls += 1
            x = np.asarray(arg[0], dtype=np.float64).reshape(-1)
            return [ca.DM(np.asarray(self._jac(x), dtype=np.float64).reshape(self._m, self._n))]

    class WithJacobian(ca.Callback):
        """``x -> f(x)`` (``m`` values) with the exact Jacobian ``jac(x)`` (``(m, n)``)."""

        def __init__(self, name: str, n: int, m: int, fun: Callable[[np.ndarray], np.ndarray],
                     jac: Callable[[np.ndarray], np.ndarray]):
            ca.Callback.__init__(self)
            self._n, self._m, self._fun = n, m, fun
            self.jacobian_callback = Jacobian(f"{name}_jac", n, m, jac)   # kept alive with this object
            self.calls = 0
            self.construct(name, {})

        def get_n_in(self):
            return 1

        def get_n_out(self):
            return 1

        def get_sparsity_in(self, i):
            return ca.Sparsity.dense(self._n, 1)

        def get_sparsity_out(self, i):
            return ca.Sparsity.dense(self._m, 1)

        def eval(self, arg):
            self.calls += 1
            x = np.asarray(arg[0], dtype=np.float64).reshape(-1)
            return [ca.DM(np.atleast_1d(np.asarray(self._fun(x), dtype=np.float64)))]

        def has_jacobian(self):
            return True

        def get_jacobian(self, name, inames, onames, opts):
            return self.jacobian_callback

    return WithJacobian


def solve(fun, grad, cons, cjac, x0: np.ndarray, lb: np.ndarray | None, ub: np.ndarray | None, m: int,
          tol: float, constraint_tol: float, maxiter: int):
    """Minimise ``fun(x)`` subject to ``cons(x) = 0`` (``m`` values) and ``lb <= x <= ub`` with IPOPT.

    Parameters
    ----------
    fun, grad : callables ``(n,) -> float`` and ``(n,) -> (n,)``
        Cost and its gradient.
    cons, cjac : callables ``(n,) -> (m,)`` and ``(n,) -> (m, n)``
        Equality constraints and their Jacobian.
    x0 : (n,) ndarray
        Starting point.
    lb, ub : None or (n,) ndarrays
        Box bounds (``None``: free).
    tol, constraint_tol, maxiter
        IPOPT's ``tol`` (scaled KKT error), ``constr_viol_tol`` and ``max_iter``.
    m : int
        Number of constraints.

    Returns
    -------
    scipy.optimize.OptimizeResult
        ``x``, ``success``, ``message`` (IPOPT's return status), ``nit``, ``nfev`` (constraint
        evaluations), ``njev`` (constraint Jacobians), ``fun``.
    """
    from scipy.optimize import OptimizeResult

    ca = require_casadi()
    WithJacobian = _callbacks(ca)
    n = x0.size
    f_cb = WithJacobian("lgvi_cost", n, 1, lambda x: fun(x), lambda x: np.asarray(grad(x)).reshape(1, n))
    g_cb = WithJacobian("lgvi_terminal", n, m, cons, cjac)
    x = ca.MX.sym("x", n)
    opts = {
        "ipopt.hessian_approximation": "limited-memory",
        "ipopt.tol": tol,
        "ipopt.constr_viol_tol": constraint_tol,
        # no "acceptable level" exit (IPOPT's default accepts a KKT error of 1e-6 after 15 stalled
        # iterations): it stops at tol or fails at max_iter
        "ipopt.acceptable_iter": 0,
        "ipopt.max_iter": maxiter,
        # the box is hard (|u_i| <= max_torque_i exactly): IPOPT relaxes bounds by 1e-8 by default
        "ipopt.bound_relax_factor": 0.0,
        "ipopt.honor_original_bounds": "yes",
        "ipopt.print_level": 0,
        "ipopt.sb": "yes",
        "print_time": False,
    }
    solver = ca.nlpsol("lgvi_transfer", "ipopt", {"x": x, "f": f_cb(x), "g": g_cb(x)}, opts)
    inf = np.full(n, np.inf)
    sol = solver(x0=x0, lbx=-inf if lb is None else lb, ubx=inf if ub is None else ub, lbg=np.zeros(m),
                 ubg=np.zeros(m))
    stats = solver.stats()
    xs = np.asarray(sol["x"], dtype=np.float64).reshape(-1).copy()
    status = str(stats.get("return_status", "unknown"))
    return OptimizeResult(x=xs, fun=float(sol["f"]), success=status == "Solve_Succeeded", message=status,
                          nit=int(stats.get("iter_count", 0)), nfev=g_cb.calls, njev=g_cb.jacobian_callback.calls)
