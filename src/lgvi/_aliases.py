"""The old dotted names of modules that moved into subpackages (issue 11's layout).

``lgvi.streaming`` is :mod:`lgvi.io.streaming`, ``lgvi.exact`` is :mod:`lgvi.verification.exact`,
``lgvi.integrator`` is :mod:`lgvi.systems.rigid_body_run`, ``lgvi.ensemble`` is
:mod:`lgvi.systems.rigid_body_ensemble`, and so on (:data:`MOVED`): ``import lgvi.exact``, ``from lgvi import exact`` and
``monkeypatch.setattr(lgvi.exact, ...)`` reach the one real module object, never a copy, so a
patch through the old name is seen by the code that uses the new one, and objects pickled under
either name load again. The real module is imported only when its old name is (importing lgvi
does not import scipy or matplotlib through here).
"""

from __future__ import annotations

import importlib
import importlib.machinery
import sys
from types import ModuleType

#: Old dotted name -> the module's real name.
MOVED: dict[str, str] = {
    "lgvi.streaming": "lgvi.io.streaming",
    "lgvi.outputs": "lgvi.io.outputs",
    "lgvi.scenario": "lgvi.io.scenario",
    "lgvi.reference": "lgvi.verification.reference",
    "lgvi.exact": "lgvi.verification.exact",
    "lgvi.baselines": "lgvi.verification.baselines",
    # the rigid body's run and ensemble behind the system seam (issue 25)
    "lgvi.integrator": "lgvi.systems.rigid_body_run",
    "lgvi.ensemble": "lgvi.systems.rigid_body_ensemble",
}


class AliasFinder:  # a MetaPathFinder and a Loader (importlib.abc, slow to import, is not needed)
    """Finds an old name of :data:`MOVED` and loads it as the already imported real module.

    ``create_module`` returns the real module; the import system then sets its ``__spec__`` to
    the old name's spec (``importlib._bootstrap._init_module_attrs`` always does, while it keeps
    ``__name__``, ``__loader__``, ``__package__`` and ``__file__``), so ``exec_module`` puts the
    real spec back: the module stays ``lgvi.io.streaming`` in every respect, listed in
    ``sys.modules`` under both names.
    """

    def __init__(self) -> None:
        self._real_specs: dict[str, importlib.machinery.ModuleSpec | None] = {}

    def find_spec(self, fullname: str, path: object = None, target: object = None):
        if fullname not in MOVED:
            return None
        return importlib.machinery.ModuleSpec(fullname, self)

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType:
        module = importlib.import_module(MOVED[spec.name])
        self._real_specs[spec.name] = module.__spec__
        return module

    def exec_module(self, module: ModuleType) -> None:
        module.__spec__ = self._real_specs.pop(module.__spec__.name)


def install() -> None:
    """Put one :class:`AliasFinder` at the end of ``sys.meta_path`` (after the path finder, which
    no longer finds the old files); installing twice adds nothing."""
    if not any(isinstance(f, AliasFinder) for f in sys.meta_path):
        sys.meta_path.append(AliasFinder())


install()
