"""Optional compiled kernels (numba).

A few steps are loops that numpy can only write as chains of whole-array
passes over large temporaries: the crossing search of the projection
(:mod:`core.crossing_kernel`) tests millions of face pairs, each in a few
dozen arithmetic operations. numba compiles such loops; the issue that asked
for speed allows a compiled kernel only where numpy cannot reach the
target, and only with the same results.

So every kernel has a numpy twin that stays the reference: the kernel does
the same floating-point operations in the same order (numba compiles
without fast-math, so no operation is fused or reordered), and the tests
compare the two. Without numba, or with ``URBANVOX_JIT=0``, the numpy code
runs. numba is imported only when a kernel is first wanted, never at import
of :mod:`core` (QGIS loads the provider without it), and a numba that fails
to import or to compile falls back with a warning, never an error.

Compiled code is cached on disk beside the module (``__pycache__``; numba
falls back to the user's cache directory where that is read-only): the first
run on a machine compiles for a few seconds, later runs and processes load it.
"""
from __future__ import annotations

import importlib
import os
import threading
import warnings
from types import ModuleType

_loaded: dict[str, ModuleType | None] = {}
_lock = threading.Lock()


def enabled() -> bool:
    """Whether compiled kernels may run: not switched off by ``URBANVOX_JIT=0``.

    Examples
    --------
    >>> import os
    >>> os.environ["URBANVOX_JIT"] = "0"
    >>> enabled()
    False
    >>> del os.environ["URBANVOX_JIT"]
    """
    return os.environ.get("URBANVOX_JIT", "1").strip().lower() not in ("0", "false", "no", "off")


def kernels(name: str) -> ModuleType | None:
    """The compiled kernel module ``core.<name>``, or None if it cannot run.

    None when switched off (:func:`enabled`), when numba is not installed, or
    when the module fails to import (a numba too old for this numpy): the
    caller then runs its numpy code. The import is tried once per process.
    """
    if not enabled():
        return None
    with _lock:
        if name not in _loaded:
            try:
                _loaded[name] = importlib.import_module(f"{__package__}.{name}")
            except ImportError:
                _loaded[name] = None  # numba is optional: the numpy code runs
            except Exception as exc:  # a broken numba install must not stop a run
                warnings.warn(f"urbanvox: compiled kernels off ({name}: {exc}); numpy code runs instead",
                              RuntimeWarning, stacklevel=2)
                _loaded[name] = None
        return _loaded[name]
