"""Optional compiled kernels (numba).

A few steps are loops that numpy can only write as chains of whole-array
passes over large temporaries, or searches that a KD-tree answers more
generally than city data need: the binning of points into voxels and
columns (:mod:`core.grid_kernel`), the chords of the ground under roofs
(:mod:`core.ground_kernel`), the air under cover that the air front
may miss (:mod:`core.classify_kernel`), the critical cubes of the well-composed
repair (:mod:`core.manifold_kernel`), the labelling of the blocks and the
passes over them (:mod:`core.blocks_kernel`), the crossing search of the projection
(:mod:`core.crossing_kernel`, millions of face pairs, each a few dozen
arithmetic operations), the nearest data points (:mod:`core.neighbours_kernel`,
a grid of columns), the points a node tries (:mod:`core.projection_kernel`),
the quads' quality under their best split (:mod:`core.quality_kernel`),
the smoothing's Catmull-Clark step (:mod:`core.smooth_kernel`), the
elimination's support test (:mod:`core.support_kernel`), the faces between
regions (:mod:`core.surface_kernel`), the selections
of moved nodes and the faces around them (:mod:`core.topology_kernel`) and
the entities of the gmsh export (:mod:`core.export_kernel`), the text of the
mesh files' numbers (:mod:`core.row_text_kernel`), the preview's depth buffer
(:mod:`core.preview_kernel`),
the per-block sums of the measures (:mod:`core.measure_kernel`), the
faces each tile owns and the numbering and copying of the tiles' nodes
and faces into one model (:mod:`core.tiles_kernel`), the
weighted moments and least axes of the MLS planes (:mod:`core.mls_kernel`), the
cells of a mesh's sample points (:mod:`core.sampling_kernel`) and the
reader's sorting of a LAS chunk's points (:mod:`core.las_kernel`).
One more compiled module is no kernel: the allocator of numpy's large
arrays on a host's threads (:mod:`core.array_heap_kernel`), without a numpy
twin; without numba, the C library allocates as before.
numba compiles such loops; the issue that asked for speed allows a compiled
kernel only where numpy cannot reach the target, and only with the same
results.

So every kernel has a numpy twin that stays the reference: the kernel does
the same floating-point operations in the same order (numba compiles
without fast-math, so no operation is fused or reordered), and the tests
compare the two. Without numba, or with ``URBANVOX_JIT=0``, the numpy code
runs. numba is imported only when a kernel is first wanted, never at import
of :mod:`core` (QGIS loads the provider without it), and a numba that fails
to import or to compile falls back with a warning, never an error.

Compiled code is cached on disk (:func:`cache_dir`): the first run of an
install compiles what it calls (all the kernels: about 70 s on two cores),
later runs and processes load it. The
cache is kept apart for each name the package is imported under (``core`` in
the tests, ``urbanvox.core`` in QGIS): numba's own cache, one per source
file, stores the module's import name, and the other name fails to load it.
"""
from __future__ import annotations

import importlib
import importlib.util
import os
import threading
import time
import warnings
from types import ModuleType

from .errors import Cancelled

#: The kernel modules of core, each with a ``warm_up()`` (see :func:`warm_up`).
#: The reader's comes first: :func:`preload` loads them in this order while
#: a file is read, and the reader uses its own once it is loaded.
KERNELS = ("las_kernel", "array_heap_kernel", "blocks_kernel", "classify_kernel", "crossing_kernel", "export_kernel",
           "grid_kernel", "ground_kernel", "manifold_kernel", "measure_kernel", "mls_kernel", "neighbours_kernel",
           "normals_kernel", "preview_kernel", "projection_kernel", "quality_kernel", "row_text_kernel",
           "sampling_kernel", "smooth_kernel", "support_kernel", "surface_kernel", "tiles_kernel", "topology_kernel")

#: Elements (points, quads, nodes) from which a kernel is loaded for a call (:func:`kernels`).
WORTHWHILE = 1_000_000

#: Kernel calls that failed in this process (:func:`run`); the tests check it is empty.
failures: list[str] = []

_loaded: dict[str, ModuleType | None] = {}
_lock = threading.Lock()
_preloader: threading.Thread | None = None


def enabled() -> bool:
    """Whether compiled kernels may run: not switched off by ``URBANVOX_JIT=0``.

    Examples
    --------
    >>> import os
    >>> before = os.environ.get("URBANVOX_JIT")
    >>> os.environ["URBANVOX_JIT"] = "0"
    >>> enabled()
    False
    >>> _ = os.environ.pop("URBANVOX_JIT") if before is None else os.environ.update(URBANVOX_JIT=before)
    """
    return os.environ.get("URBANVOX_JIT", "1").strip().lower() not in ("0", "false", "no", "off")


def kernels(name: str, size: int | None = None) -> ModuleType | None:
    """The compiled kernel module ``core.<name>``, or None if it cannot run.

    None when switched off (:func:`enabled`), when numba is not installed, or
    when the module fails to import (a numba too old for this numpy): the
    caller then runs its numpy code. The import is tried once per process.

    Also None for work of ``size`` below :data:`WORTHWHILE` elements while
    no kernel is loaded: importing numba and loading the first compiled
    code take about 0.3 s and 100 MB once per process, more than small
    data gain (Delft at 1 m: 0.49 s with numpy in a fresh process, 0.54-0.66
    s with the kernels). Once one is loaded (by large work), the others
    cost a few hundredths of a second each and run for any size: Delft at
    0.5 m, whose 3.8 M voxels load the first, took 1.74-1.79 s with the
    others kept off, 1.26-1.28 s with them. ``URBANVOX_JIT=always`` loads
    them for any size from the start (the tests use it).
    """
    if not enabled() or _too_small(size):
        return None
    with _lock:
        if name not in _loaded:
            try:
                import numba
            except ImportError:
                _loaded[name] = None  # numba is optional: the numpy code runs
                return None
            # numba picks a function's cache directory when it is decorated,
            # at import: the package's own directory then, and numba's
            # setting as it was afterwards.
            saved = numba.config.CACHE_DIR
            numba.config.CACHE_DIR = cache_dir() or saved
            try:
                _loaded[name] = importlib.import_module(f"{__package__}.{name}")
            except Exception as exc:  # a broken numba install must not stop a run
                _loaded[name] = None
                _warn(name, exc)
            finally:
                numba.config.CACHE_DIR = saved
        return _loaded[name]


def expected(size: int) -> bool:
    """Whether work of ``size`` elements will run compiled kernels
    (:func:`kernels`), without loading them: for an estimate made before
    the work (the memory guard's). A numba that is installed but fails to
    load is not foreseen.

    Examples
    --------
    >>> before = os.environ.get("URBANVOX_JIT")
    >>> os.environ["URBANVOX_JIT"] = "0"
    >>> expected(10**9)
    False
    >>> _ = os.environ.pop("URBANVOX_JIT") if before is None else os.environ.update(URBANVOX_JIT=before)
    """
    if not enabled() or _too_small(size):
        return False
    return importlib.util.find_spec("numba") is not None


def _too_small(size: int | None) -> bool:
    """Whether work of ``size`` elements is too small to load kernels for (see :func:`kernels`)."""
    return size is not None and size < WORTHWHILE and not _any_loaded() and not _always()


def ready(name: str) -> bool:
    """Whether the kernel module ``core.<name>`` is loaded in this process
    already (by :func:`preload` or an earlier call): for a step that may run
    either way, its numpy code giving the same results, without waiting for
    a load.

    Examples
    --------
    >>> ready("no_such_kernel")
    False
    """
    return enabled() and _loaded.get(name) is not None


def _any_loaded() -> bool:
    """Whether a kernel module is loaded in this process (so numba is imported)."""
    return any(module is not None for module in _loaded.values())


def _always() -> bool:
    """``URBANVOX_JIT=always``: kernels for work of any size."""
    return os.environ.get("URBANVOX_JIT", "").strip().lower() == "always"


def run(name: str, function: str, *args, size: int | None = None):
    """``core.<name>.<function>(*args)``, or None if the kernel cannot run.

    None when :func:`kernels` has no module (for work of ``size`` elements,
    see there), or when the call fails (a cache that cannot be read, a numba
    that cannot compile): the kernel is then
    off for the rest of the process, with a warning, and the caller runs
    its numpy code. :class:`core.errors.Cancelled` is raised as it comes.
    """
    module = kernels(name, size)
    if module is None:
        return None
    try:
        return getattr(module, function)(*args)
    except Cancelled:
        raise
    except Exception as exc:
        with _lock:
            _loaded[name] = None
            failures.append(f"{name}.{function}: {exc!r}")
        _warn(name, exc)
        return None


def preload(size: int | None = None, after: float = 0.0) -> threading.Thread | None:
    """Load every kernel on a thread of its own, for work of ``size``
    elements that loads them anyway (:func:`kernels`), while the caller goes
    on with numpy work; None (nothing started) when that work is too small,
    the kernels are off, or a preload was already started in this process.
    ``size`` None: a run of any size is coming and the process is idle until
    then (a Processing dialog is open: the user is choosing its parameters),
    so the kernels load first, ``after`` seconds from now (the dialog builds
    meanwhile, without the loading's hold on the GIL).

    Loading them in a fresh process takes about 0.45 s, paid by every
    command-line run and every Dask worker's first tile. Loading holds the
    GIL, so it overlaps little with the caller's numpy work: the reader and
    the pipeline preload for many points only (a large file decodes
    meanwhile). For small data a kernel loads at its first call, and the
    kernels a run does not use never load (Delft at 0.5 m: 1.23-1.27 s of
    method in a first run, 1.25-1.32 s with a preload). The first call of a
    kernel that is still loading waits for it (numba's compiler lock).
    Returns the thread.
    """
    global _preloader
    if not enabled() or (size is not None and size < WORTHWHILE and not _always()):
        return None
    with _lock:
        if _preloader is not None:
            return None
        _preloader = threading.Thread(target=_warm_up_after, args=(after,), name="urbanvox-kernels", daemon=True)
    _preloader.start()
    return _preloader


def cache_dir() -> str | None:
    """Where compiled kernels are cached: ``__pycache__/numba/<package>`` beside
    this module, else (read-only install) under the user's cache directory;
    None if neither can be written (numba then chooses)."""
    user_cache = os.environ.get("XDG_CACHE_HOME") or os.environ.get("LOCALAPPDATA") \
        or os.path.join(os.path.expanduser("~"), ".cache")
    for base in (os.path.join(os.path.dirname(os.path.abspath(__file__)), "__pycache__"),
                 os.path.join(user_cache, "urbanvox")):
        path = os.path.join(base, "numba", __package__)
        try:
            os.makedirs(path, exist_ok=True)
        except OSError:
            continue
        if os.access(path, os.W_OK):
            return path
    return None


def _warn(name: str, exc: BaseException) -> None:
    warnings.warn(f"urbanvox: compiled kernel {name} off ({exc!r}); the numpy code runs instead",
                  RuntimeWarning, stacklevel=3)


def _warm_up_after(seconds: float) -> None:
    time.sleep(seconds)
    warm_up()


def warm_up() -> list[str]:
    """Compile every kernel for the argument types the pipeline passes (or
    load them from the cache): ``make setup`` runs it (``python -m
    core.jit``), so that the first reconstruction does not wait for it.
    Returns the kernel modules that can run."""
    return [name for name in KERNELS if run(name, "warm_up") is not None]


if __name__ == "__main__":
    start = time.perf_counter()
    names = warm_up()
    print(f"compiled kernels: {', '.join(names) or 'none (numba missing or URBANVOX_JIT=0)'}"
          f" ({time.perf_counter() - start:.1f} s)")
