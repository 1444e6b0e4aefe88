"""The one place Numba is configured.

Every compiled kernel in :mod:`lgvi._kernels` is decorated with :func:`jit` from here, so the
compilation options live in a single spot:

* ``nopython`` mode, always (no object-mode fallback);
* ``cache=True`` unless the environment variable ``LGVI_NUMBA_CACHE`` is ``0``. The cache lives in
  ``NUMBA_CACHE_DIR`` when it is set, else in the user's cache folder (:func:`user_cache_dir`:
  ``$XDG_CACHE_HOME/lgvi/numba`` or ``~/.cache/lgvi/numba`` on Linux, ``~/Library/Caches/lgvi/numba``
  on macOS, ``%LOCALAPPDATA%\\lgvi\\Cache\\numba`` on Windows), never inside the installed package
  unless neither is writable. When no cache location is writable (a read-only install with an unwritable ``NUMBA_CACHE_DIR`` and home),
  Numba refuses ``cache=True``; the kernels are then compiled in memory and a warning says so;
* ``fastmath`` is never enabled: conservation to round-off depends on IEEE semantics;
* the cache of every kernel is keyed by a hash of *all* the kernel sources. Numba's own key is
  the defining file's time stamp only, so after an edit of ``solvers.py`` a cached kernel of
  ``stepping.py`` would keep the old solver inlined (an in-place upgrade or a development tree
  would silently mix versions); with the hash, any change of any kernel file recompiles them all.
  The hash covers this file too (the options above shape every kernel's code);
* the cache is kept apart per Numba setting that changes the machine code (``NUMBA_OPT``,
  ``NUMBA_BOUNDSCHECK``, ``NUMBA_DEBUGINFO``, the vectorisers, AVX: :data:`_CODEGEN_SETTINGS`), a
  sub-folder each: Numba's own key (the signature, the CPU, the bytecode) holds none of them, so a
  run with ``NUMBA_BOUNDSCHECK=1`` or ``NUMBA_OPT=0`` would leave its slower kernels in the cache and
  every later run of the tree would load them.

Numba's typing of built-in functions and operators is remembered for plain argument types
(:func:`_install_typing_memo`: the same answers, found once; a fifth of a cold compilation).

When a compilation of lgvi's kernels takes longer than a second (a fresh install, an upgrade, a
new model), one line on the ``lgvi`` logger (shown on stderr unless logging is configured) says
so; loading compiled kernels from the cache says nothing.

Setting ``NUMBA_DISABLE_JIT=1`` runs every kernel as plain Python (slow, but identical maths),
which the test suite uses to check the kernels interpreted.
"""

from __future__ import annotations

import hashlib
import logging
import os
import sys
import threading
import time
import types
import warnings
from typing import Any, Callable

import numba

CACHE: bool = os.environ.get("LGVI_NUMBA_CACHE", "1").strip().lower() not in {"0", "false", "no", "off"}

_OPTIONS: dict[str, Any] = {"nogil": True, "error_model": "numpy"}
_KERNELS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "_kernels")


def _key_files() -> list[str]:
    """The files whose text keys the cache: every kernel source and this file (the options)."""
    kernels = [os.path.join(_KERNELS, name) for name in sorted(os.listdir(_KERNELS)) if name.endswith(".py")]
    return kernels + [os.path.abspath(__file__)]


def _kernel_sources_hash() -> str:
    digest = hashlib.sha256()
    for path in _key_files():
        digest.update(os.path.basename(path).encode())
        with open(path, "rb") as fh:
            digest.update(fh.read())
    return digest.hexdigest()


#: Numba settings (``numba.core.config``) that change a kernel's machine code and are not in Numba's
#: cache key: the cache of lgvi's kernels has a sub-folder per combination (:func:`_codegen_tag`).
_CODEGEN_SETTINGS = ("OPT", "BOUNDSCHECK", "DEBUGINFO_DEFAULT", "LOOP_VECTORIZE", "SLP_VECTORIZE", "ENABLE_AVX",
                     "EXTEND_VARIABLE_LIFETIMES")


def _codegen_tag() -> str:
    """The name of the cache sub-folder of this process's Numba settings (:data:`_CODEGEN_SETTINGS`)."""
    from numba.core import config

    values = repr([(name, str(getattr(config, name, None))) for name in _CODEGEN_SETTINGS])
    return "cg-" + hashlib.sha256(values.encode()).hexdigest()[:12]


def user_cache_dir() -> str:
    """The folder of lgvi's compiled kernels in the user's cache folder (the platform's convention)."""
    if sys.platform == "win32":
        base = os.environ.get("LOCALAPPDATA") or os.path.expanduser(os.path.join("~", "AppData", "Local"))
        return os.path.join(base, "lgvi", "Cache", "numba")
    if sys.platform == "darwin":
        return os.path.expanduser(os.path.join("~", "Library", "Caches", "lgvi", "numba"))
    base = os.environ.get("XDG_CACHE_HOME") or os.path.expanduser(os.path.join("~", ".cache"))
    return os.path.join(base, "lgvi", "numba")


def _install_cache_key() -> None:
    """Key the Numba cache of lgvi's kernels by the hash of all kernel sources (see above).

    This uses Numba's cache locator classes; should their layout change, lgvi falls back to
    Numba's default key (the defining file's stamp), which is correct for installed releases.
    """
    try:
        from numba.core import caching

        stamp = ("lgvi-kernels", _kernel_sources_hash())
        tag = _codegen_tag()
        # public names in recent Numba; underscored (private) in 0.59 to 0.61. The order is the
        # preference: NUMBA_CACHE_DIR, the user's cache folder, next to the source as a last resort
        provided, in_tree, user_wide = [getattr(caching, name, None) or getattr(caching, "_" + name)
                                        for name in ("UserProvidedCacheLocator", "InTreeCacheLocator",
                                                     "UserWideCacheLocator")]
        bases = [provided, user_wide, in_tree]
    except Exception:  # pragma: no cover - a Numba without these internals
        return

    def make(base: type) -> type:
        class Locator(base):  # type: ignore[misc, valid-type]
            def __init__(self, py_func, py_file):
                super().__init__(py_func, py_file)
                if base is user_wide:
                    self._cache_path = os.path.join(user_cache_dir(), self.get_suitable_cache_subpath(py_file))
                # a sub-folder per code-shaping Numba setting: Numba's key would load one run's
                # NUMBA_OPT=0 or bounds-checked kernels in every later run
                self._cache_path = os.path.join(self._cache_path, tag)

            @classmethod
            def from_function(cls, py_func, py_file):
                if os.path.dirname(os.path.abspath(py_file)) != _KERNELS:
                    return None
                return super().from_function(py_func, py_file)

            def get_source_stamp(self):
                return stamp

        Locator.__name__ = f"Lgvi{base.__name__}"
        return Locator

    classes = caching.CacheImpl._locator_classes
    if not any(c.__name__.startswith("Lgvi") for c in classes):
        classes[0:0] = [make(b) for b in bases]
    _install_save_lock(caching)


def _install_save_lock(caching: Any) -> None:
    """Serialise the saving of lgvi's cached kernels between processes (a file lock per index).

    Numba saves a kernel by reading the index of its cache, choosing the first free data-file name
    and writing the index and the data (each by an atomic rename, but the read-modify-write is not
    locked). Two processes saving *different* signatures of one kernel at once (the test suite's
    two workers, two ensembles started together) can choose the same data-file name: one entry is
    lost, or the index points one signature at the other's code. Holding ``<index>.lock``
    (``fcntl.flock``) around the save of an lgvi kernel closes that; elsewhere (no ``fcntl``, a
    folder where the lock file cannot be made) Numba's own save runs as before.
    """
    cls = getattr(caching, "IndexDataCacheFile", None)
    original = getattr(cls, "save", None)
    if original is None or getattr(original, "_lgvi_locked", False):
        return
    try:
        import fcntl
    except ImportError:  # pragma: no cover - Windows
        return

    def save(self: Any, key: Any, data: Any) -> None:
        index = getattr(self, "_index_path", "")
        if "_kernels" not in index:           # not one of lgvi's kernels: Numba's own save
            return original(self, key, data)
        try:
            fh = open(index + ".lock", "a+b")
        except OSError:
            return original(self, key, data)
        with fh:
            fcntl.flock(fh, fcntl.LOCK_EX)
            try:
                return original(self, key, data)
            finally:
                fcntl.flock(fh, fcntl.LOCK_UN)

    save._lgvi_locked = True  # type: ignore[attr-defined]
    cls.save = save


if CACHE:
    _install_cache_key()
_warned = False

#: Seconds a compilation of lgvi's kernels runs before the line saying so appears.
COMPILE_NOTICE_AFTER = 1.0
_log = logging.getLogger("lgvi")


#: Per thread: ``depth`` of the compilations under way, ``compiling`` (the notice's timer) and ``lgvi``
#: (True while the outermost compilation is one of lgvi's kernels: the typing memo's scope).
_COMPILING = threading.local()


def _install_compile_notice() -> None:
    """Say on the ``lgvi`` logger when compiling lgvi's kernels takes longer than a second.

    Numba's event API reports each compilation (a cache miss; a load from the cache is none). The
    outermost one of a thread starts a timer that says it once ``COMPILE_NOTICE_AFTER`` seconds
    have passed; its end cancels the timer, and says it then if the timer could not run in time
    (a busy machine). Nothing runs on the hot path.
    """
    try:
        from numba.core import event
    except ImportError:  # pragma: no cover - a Numba without the event API
        return
    local = _COMPILING

    class Compiling:
        def __init__(self, name: str) -> None:
            self.name, self.start, self.lock, self.said = name, time.perf_counter(), threading.Lock(), False
            self.timer = threading.Timer(COMPILE_NOTICE_AFTER, self.say)
            self.timer.daemon = True
            self.timer.start()

        def say(self) -> None:
            with self.lock:
                if self.said:
                    return
                self.said = True
            kept = "cached for the next runs" if CACHE else "in memory only: LGVI_NUMBA_CACHE=0"
            _log.warning("lgvi: compiling the kernel %s for this model (first use; %s)", self.name, kept)

        def end(self) -> None:
            self.timer.cancel()
            if time.perf_counter() - self.start >= COMPILE_NOTICE_AFTER:
                self.say()

    class Listener(event.Listener):
        def on_start(self, ev: Any) -> None:
            depth = getattr(local, "depth", 0)
            local.depth = depth + 1
            if depth == 0:
                func = getattr((ev.data or {}).get("dispatcher"), "py_func", None)
                ours = (getattr(func, "__module__", None) or "").startswith("lgvi.")
                local.compiling = Compiling(func.__name__) if ours else None
                local.lgvi = ours         # the typing memo serves this compilation (and what it compiles)

        def on_end(self, ev: Any) -> None:
            local.depth = max(getattr(local, "depth", 1) - 1, 0)
            if local.depth == 0:
                local.lgvi = False
                if getattr(local, "compiling", None) is not None:
                    local.compiling.end()
                    local.compiling = None

    event.register("numba:compile", Listener())


_install_compile_notice()


#: ``LGVI_TYPING_MEMO=0`` leaves Numba's typing of functions as it is (to measure what the memo saves).
TYPING_MEMO: bool = os.environ.get("LGVI_TYPING_MEMO", "1").strip().lower() not in {"0", "false", "no", "off"}

#: Numba types whose typing by a function's templates depends on nothing but the types themselves
#: (see :func:`_install_typing_memo`).
_PLAIN_TYPE_NAMES = ("Number", "Boolean", "Array", "NoneType", "SliceType")
#: The memo: ``(function type, typing context, target, argument types)`` -> the signature Numba found
#: and the implementation key it recorded for the signature's arguments.
_TYPING_MEMO: dict[Any, Any] = {}


def _install_typing_memo() -> None:
    """Remember how Numba typed a built-in function or operator for given argument types.

    Numba types every call site of a function by trying the function's templates in turn
    (``types.Function.get_call_type``): ``a * b`` on two floats tries the NumPy ufunc templates, the
    array operators and the scalar rules, each time, at every site; and it types each operator again
    when it lowers it. In the stepping loops, thousands of scalar operations and array accesses of a
    few dozen distinct kinds, this is a fifth of a cold first call's compilation. The answer depends
    only on the function and the argument types (and the target), so it is memoised here for
    arguments that are plain data types (numbers, booleans, arrays, ``None``, slices and tuples of
    them; their literal values are part of the types and so of the key): the same signature and
    implementation key, found once. Failures are not remembered (Numba raises them as before),
    nor are calls with keywords or with other argument types (functions, records, ...). Should the
    internals used here change, Numba's own typing runs as before; ``LGVI_TYPING_MEMO=0`` turns the
    memo off. It serves only the compilations of lgvi's own kernels (and what they compile inside
    them): while the outermost compilation of the thread is one of lgvi's (``_COMPILING.lgvi``, set by
    the compile listener above); a user's ``numba.njit`` function is typed by Numba alone.
    """
    try:
        from numba.core import types as nbtypes
        from numba.core.target_extension import get_local_target
        from numba.core.types.functions import BaseFunction

        plain = tuple(getattr(nbtypes, name) for name in _PLAIN_TYPE_NAMES)
        tuples = (nbtypes.UniTuple, nbtypes.Tuple)
    except (ImportError, AttributeError):  # pragma: no cover - a Numba without these internals
        return
    original = getattr(BaseFunction, "get_call_type", None)
    if original is None or getattr(original, "_lgvi_memo", False) or not TYPING_MEMO:
        return
    memo = _TYPING_MEMO

    def is_plain(a: Any) -> bool:
        if type(a) in tuples:
            return all(is_plain(x) for x in a.types)
        return isinstance(a, plain)

    scope = _COMPILING

    def get_call_type(self: Any, context: Any, args: Any, kws: Any) -> Any:
        if kws or not getattr(scope, "lgvi", False) or not all(is_plain(a) for a in args):
            return original(self, context, args, kws)
        key = (self, context, get_local_target(context), tuple(args))
        hit = memo.get(key)
        if hit is None:
            sig = original(self, context, args, kws)      # raises when no template matches
            keys = getattr(self, "_impl_keys", None)
            if sig is not None and keys is not None and sig.args in keys:
                memo[key] = (sig, keys[sig.args])
            return sig
        # Numba's own typing records which implementation serves the signature's arguments (the
        # lowering reads it); two argument tuples typed to the same signature's arguments by
        # different templates would leave the other's there: put this one's back, as Numba would
        sig, impl = hit
        self._impl_keys[sig.args] = impl
        return sig

    get_call_type._lgvi_memo = True  # type: ignore[attr-defined]
    BaseFunction.get_call_type = get_call_type


_install_typing_memo()


def _compile(func: Callable, options: dict[str, Any]) -> Callable:
    global _warned
    try:
        return numba.njit(cache=CACHE, **options)(func)
    except RuntimeError as exc:
        if "cannot cache" not in str(exc):
            raise
        if not _warned:
            warnings.warn(f"lgvi: Numba cannot cache the kernels here ({exc}); compiling them in memory on "
                          "every run. Set NUMBA_CACHE_DIR to a writable folder to keep the compiled kernels.",
                          RuntimeWarning, stacklevel=3)
            _warned = True
        return numba.njit(cache=False, **options)(func)


def _decorator(extra: dict[str, Any]) -> Callable:
    def jit(func: Callable | None = None, **kwargs: Any) -> Callable:
        options = {**_OPTIONS, **extra, **kwargs}
        if options.pop("cache", True) is False:      # a kernel that takes a user's function
            if func is None:
                return lambda f: numba.njit(cache=False, **options)(f)
            return numba.njit(cache=False, **options)(func)
        if func is None:
            return lambda f: _compile(f, options)
        return _compile(func, options)

    return jit


#: ``@jit`` or ``@jit(**numba_options)`` compiles in nopython mode with the project's options.
jit = _decorator({})

#: Parallel variant, for kernels with a ``numba.prange`` loop over independent bodies.
jit_parallel = _decorator({"parallel": True})



def jit_copy(func: Callable, name: str, doc: str, **kwargs: Any) -> Callable:
    """Compile the Python source of the ``inline="always"`` helper ``func`` again as a function of its
    own named ``name`` (``@jit(**kwargs)``): the same arithmetic, bit for bit, callable without
    inlining.

    Inlining at Numba's level runs the helper's front end again at every call site and deep-copies
    its IR, block by block, with all its variables (a cost that grows with the square of the
    helper's size); a wrapper ``def f_call(...): return f(...)`` pays that copy once more. The copy
    made here is compiled from the source directly, so a large helper costs one front end and no
    IR copy. The copy has its own name, so Numba's cache keeps it apart from ``func``.
    """
    py = getattr(func, "py_func", func)
    copy = types.FunctionType(py.__code__, py.__globals__, name, py.__defaults__, py.__closure__)
    copy.__qualname__ = name
    copy.__module__ = py.__module__
    copy.__kwdefaults__ = py.__kwdefaults__
    copy.__doc__ = doc
    return jit(**kwargs)(copy)


__all__ = ["CACHE", "jit", "jit_copy", "jit_parallel"]
