"""Compiled layer: Numba kernels on float64 arrays, no Python objects.

Everything here is decorated with :func:`lgvi._jit.jit` and is called only by the Python layer
(:mod:`lgvi.implicit`, :mod:`lgvi.systems.rigid_body_run`), which validates inputs first.
"""
