"""The input/output layer: files that a run reads and writes.

- :mod:`lgvi.io.streaming`: crash-safe stream folders (``simulate_stream``, ``read_stream``);
- :mod:`lgvi.io.outputs`: trajectory files (``.npz``, ``.csv``, ``.nc``) and conservation drifts;
- :mod:`lgvi.io.scenario`: scenario files (TOML) and running them.

The core (``lgvi.driver``, ``lgvi.integrator``, the systems, models and kernels) never imports
this package (``tests/test_layers.py``); the old names ``lgvi.streaming``, ``lgvi.outputs`` and
``lgvi.scenario`` are these same modules. Nothing here is imported until used.
"""
