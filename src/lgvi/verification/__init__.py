"""Verification: references to check the integrator against, none of them used by it.

- :mod:`lgvi.verification.exact`: the torque-free body in closed form (Jacobi elliptic functions);
- :mod:`lgvi.verification.reference`: the paper's equations in plain NumPy, the oracle for the
  compiled kernels;
- :mod:`lgvi.verification.baselines`: classical integrators (RK4, ``solve_ivp``) on the same
  problems, and :func:`~lgvi.verification.baselines.compare`.

The core never imports this package (``tests/test_layers.py``); the old names ``lgvi.exact``,
``lgvi.reference`` and ``lgvi.baselines`` are these same modules. Nothing here is imported until
used (``exact`` imports SciPy).
"""
