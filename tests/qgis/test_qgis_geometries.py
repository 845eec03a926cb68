"""The layers' geometries made on threads of their own (processing_provider/algorithms/geometries.py)."""

import threading

import numpy as np
import pytest


def wkbs(count):
    """``count`` MultiPolygonZ WKB of 1 to ``count`` triangles each, and the shapely geometries."""
    import shapely

    from urbanvox.core.wkb import multipolygons_z

    rng = np.random.default_rng(count)
    nodes = rng.random((50, 3)) * 100
    sizes = np.arange(1, count + 1)
    faces = rng.integers(0, 50, (int(sizes.sum()), 3))
    made = list(multipolygons_z(nodes, faces, np.repeat(np.arange(count), sizes), count))
    return made, [shapely.from_wkb(w) for w in made]


def test_the_feed_gives_each_geometry_in_order_made_on_its_own_thread(urbanvox_plugin):
    from urbanvox.processing_provider.algorithms.geometries import AHEAD, GeometryFeed

    made, shapes = wkbs(3 * AHEAD)
    callers = []

    def source():
        callers.append(threading.current_thread().name)
        yield from made

    with GeometryFeed(source) as feed:
        got = []
        for geometry in feed:
            got.append((geometry.constGet().numGeometries(), geometry.area(), geometry.vertexAt(0).z()))
            feed.written(geometry)
    assert callers == ["urbanvox-geometries"]
    wanted = [(len(s.geoms), s.area, s.geoms[0].exterior.coords[0][2]) for s in shapes]
    assert np.array(got) == pytest.approx(np.array(wanted), rel=1e-12)
    assert not any(t.name == "urbanvox-geometries" for t in threading.enumerate())


def test_one_thread_makes_the_layers_in_turn_the_next_ahead_of_the_writer(urbanvox_plugin):
    # One thread for every layer: the memory of a layer's geometries in its
    # heap serves the next (a thread each took 450 MB more for the 1 km city's
    # ground, through a GeoPackage layer's exporter).
    from urbanvox.processing_provider.algorithms.geometries import AHEAD, GeometryFeed

    first, _ = wkbs(AHEAD + 2)
    second, second_shapes = wkbs(5)
    threads, started = [], threading.Event()

    def source(made, then=None):
        def make():
            threads.append(threading.get_ident())
            if then is not None:
                then.set()
            yield from made
        return make

    with GeometryFeed(source(first), source(second, started)) as feed:
        taken = 0
        for geometry in feed.layer(0):
            taken += 1
            if taken == 3:
                # The rest of the first layer is queued: the thread goes on with the second.
                assert started.wait(5)
            feed.written(geometry)
        assert taken == len(first)
        got = [geometry.constGet().numGeometries() for geometry in feed.layer(1)]
    assert got == [len(shape.geoms) for shape in second_shapes]
    assert len(threads) == 2 and threads[0] == threads[1] != threading.get_ident()
    assert not any(t.name == "urbanvox-geometries" for t in threading.enumerate())


def test_an_error_of_the_source_is_raised_to_the_writer_after_the_geometries_before_it(urbanvox_plugin):
    from urbanvox.processing_provider.algorithms.geometries import GeometryFeed

    made, _ = wkbs(3)

    def source():
        yield from made
        raise MemoryError("no room for the ground")

    got = 0
    with pytest.raises(MemoryError, match="no room"), GeometryFeed(source) as feed:
        for _ in feed:
            got += 1
    assert got == 3

    # In a later layer: the layers before it whole, then the error where that layer is taken.
    got = []
    with pytest.raises(MemoryError, match="no room"), GeometryFeed(lambda: made, source) as feed:
        got.append(len(list(feed.layer(0))))
        for _ in feed.layer(1):
            got.append("ground")
    assert got == [3, "ground", "ground", "ground"]


def test_an_exception_beyond_exception_still_reaches_the_writer(urbanvox_plugin):
    # Caught as Exception only, it ended the feed's thread without a word, and
    # the writer waited for the next geometry forever.
    from urbanvox.processing_provider.algorithms.geometries import GeometryFeed

    class Interrupted(BaseException):
        pass

    def source():
        raise Interrupted()
        yield

    with pytest.raises(Interrupted), GeometryFeed(source) as feed:
        list(feed)


def test_a_writer_that_stops_early_stops_the_feed(urbanvox_plugin):
    # A sink that fails mid-layer: leaving the feed ends its thread, which was
    # waiting with a full queue on an endless source.
    from urbanvox.processing_provider.algorithms.geometries import GeometryFeed

    made, _ = wkbs(1)

    def endless():
        while True:
            yield made[0]

    with pytest.raises(RuntimeError, match="disk full"), GeometryFeed(endless) as feed:
        for index, _ in enumerate(feed):
            if index == 5:
                raise RuntimeError("disk full")
    assert not feed._thread.is_alive()
