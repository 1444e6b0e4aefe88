"""The package's version: the installed distribution's (set from the repository's tags by hatch-vcs
when the package is built or installed), or ``0+unknown`` for a source tree that was never installed."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__: str = version("lgvi")
except PackageNotFoundError:  # pragma: no cover - a source tree on sys.path without an install
    __version__ = "0+unknown"
