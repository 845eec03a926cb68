"""Optional compiled kernels (core.jit): switched off, failing, cached, and
the pipeline's model the same with them or without."""
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from core import jit

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def kernel(compiled):
    return compiled("crossing_kernel")


@pytest.fixture(autouse=True)
def no_preload_running():
    # A pipeline run of an earlier test may have started loading the kernels
    # on a thread (jit.preload): the tests below swap the loaded modules.
    if jit._preloader is not None:
        jit._preloader.join()


def test_switched_off_by_the_environment(monkeypatch, kernel):
    monkeypatch.setenv("URBANVOX_JIT", "0")
    assert jit.kernels("crossing_kernel") is None
    monkeypatch.setenv("URBANVOX_JIT", "1")
    assert jit.kernels("crossing_kernel") is kernel


def test_small_work_does_not_load_the_kernels(monkeypatch):
    # Importing numba and loading the kernels costs more than small data gain;
    # once one is loaded (by large work), every kernel runs for any size.
    monkeypatch.delenv("URBANVOX_JIT", raising=False)
    monkeypatch.setattr(jit, "_loaded", {})
    assert jit.kernels("crossing_kernel", 1000) is None and "crossing_kernel" not in jit._loaded
    assert jit.kernels("quality_kernel", 1000) is None and "quality_kernel" not in jit._loaded
    module = jit.kernels("crossing_kernel", jit.WORTHWHILE)
    assert module is not None and jit.kernels("crossing_kernel", 1000) is module
    assert jit.kernels("quality_kernel", 1000) is not None


def test_a_preload_loads_every_kernel_for_large_or_coming_work_only_once(compiled, monkeypatch):
    compiled("quality_kernel")  # numba is there (the fixture asserts it)
    monkeypatch.delenv("URBANVOX_JIT", raising=False)
    monkeypatch.setattr(jit, "_loaded", {})
    monkeypatch.setattr(jit, "_preloader", None)
    assert jit.preload(jit.WORTHWHILE - 1) is None and jit._loaded == {}
    thread = jit.preload(jit.WORTHWHILE)
    assert thread is not None and jit.preload(jit.WORTHWHILE) is None  # one per process
    thread.join(timeout=300)
    assert not thread.is_alive()
    assert sorted(name for name, module in jit._loaded.items() if module is not None) == sorted(jit.KERNELS)
    # No size: a run of any size is coming (a Processing dialog is open), after a delay.
    monkeypatch.setattr(jit, "_loaded", {})
    monkeypatch.setattr(jit, "_preloader", None)
    thread = jit.preload(after=1.0)
    assert thread is not None and jit._loaded == {}  # still waiting
    thread.join(timeout=300)
    assert sorted(name for name, module in jit._loaded.items() if module is not None) == sorted(jit.KERNELS)
    monkeypatch.setattr(jit, "_preloader", None)
    monkeypatch.setenv("URBANVOX_JIT", "0")
    assert jit.preload(jit.WORTHWHILE) is None and jit.preload() is None


def test_a_failing_kernel_falls_back_to_numpy_with_a_warning(kernel, monkeypatch):
    # kernel first: its check of jit.failures runs after monkeypatch has put the list back.
    from test_intersect import stacked_grids

    from core.intersect import undo_crossings

    def broken(*args):
        raise RuntimeError("cannot load the cache")

    old, quads = stacked_grids()
    rng = np.random.default_rng(0)
    moved = rng.random(len(old)) < 0.5
    new = old.copy()
    new[moved] += rng.normal(scale=0.25, size=(moved.sum(), 3))
    expected = undo_crossings(old, new, moved, quads)
    monkeypatch.setattr(kernel, "crossing_triangles", broken)
    monkeypatch.setattr(jit, "failures", [])
    monkeypatch.setitem(jit._loaded, "crossing_kernel", kernel)  # put back as it was afterwards
    with pytest.warns(RuntimeWarning, match="crossing_kernel off"):
        positions, kept, undone = undo_crossings(old, new, moved, quads)
    assert undone == expected[2] > 0 and np.array_equal(positions, expected[0])
    assert jit.kernels("crossing_kernel") is None and len(jit.failures) == 1


def test_the_cache_is_kept_apart_for_each_import_name():
    # numba's cache stores the module's import name: QGIS imports the plugin
    # as urbanvox.core, the tests as core, and each must not load the other's.
    path = jit.cache_dir()
    assert path is not None and path.endswith(os.path.join("numba", jit.__package__))
    assert os.access(path, os.W_OK)


def test_the_pipeline_gives_the_same_model_with_or_without_the_kernels(monkeypatch, compiled, district):
    from core.pipeline import ReconstructionParams, reconstruct_point_cloud

    for name in jit.KERNELS:
        compiled(name)
    results = []
    for switch in ("0", "1"):
        monkeypatch.setenv("URBANVOX_JIT", switch)
        results.append(reconstruct_point_cloud(district.laz, crs=district.crs,
                                               params=ReconstructionParams(voxel_size=1.0)))
    assert results[1].stats["projection_buildings"]["projected"] > 1000
    assert results[1].stats["projection_ground"]["projected"] > 1000
    assert results[1].stats["projection_buildings"]["crossing"] == results[0].stats["projection_buildings"]["crossing"]
    assert np.array_equal(results[0].mesh.nodes, results[1].mesh.nodes)
    assert results[0].block_rows() == results[1].block_rows()




def test_a_failing_point_index_falls_back_to_a_kd_tree(compiled, monkeypatch):
    # compiled first: its check of jit.failures runs after monkeypatch has put the list back.
    from core import neighbours

    module = compiled("neighbours_kernel")
    data = np.random.default_rng(1).uniform(0, 10, (500, 3))
    index = neighbours.point_index(data, 1.0)
    assert isinstance(index, module.ColumnIndex)
    expected = neighbours.nearest(index, data, data[:20] + 0.1, 5)

    def broken(*args):
        raise RuntimeError("no more memory")

    monkeypatch.setattr(module, "nearest_in", broken)
    monkeypatch.setattr(jit, "failures", [])
    monkeypatch.setitem(jit._loaded, "neighbours_kernel", module)
    with pytest.warns(RuntimeWarning, match="neighbours_kernel off"):
        found = neighbours.nearest(index, data, data[:20] + 0.1, 5)
    assert np.array_equal(found[0], expected[0]) and np.array_equal(found[1], expected[1])
    assert isinstance(index.fallback, neighbours.cKDTree)
    assert neighbours.point_index(data, 1.0) is not index and jit.kernels("neighbours_kernel") is None


def test_importing_core_does_not_import_numba():
    # QGIS loads the provider without numba (and a Processing run may never
    # want a kernel); a kernel module imports it when first wanted (jit.kernels).
    code = ("import importlib, pkgutil, sys, core\n"
            "for module in pkgutil.walk_packages(core.__path__, 'core.'):\n"
            "    if not module.name.endswith(('_kernel', '__main__')):\n"
            "        importlib.import_module(module.name)\n"
            "print(len(sys.modules), 'numba' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True).stdout
    count, numba_loaded = out.split()
    assert int(count) > 100 and numba_loaded == "False"
