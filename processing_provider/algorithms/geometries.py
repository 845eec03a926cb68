"""The output layers' geometries, made on a thread of their own ahead of the writer.

A layer's features take three steps: the core writes the WKB of each
geometry (numpy, :mod:`core.wkb`), QGIS parses it into a
:class:`QgsGeometry`, and the sink writes that. The first two run on a
thread of their own (:class:`GeometryFeed`) while the algorithm's thread
writes: the parse and the sink's write run in QGIS's C++ with the GIL
released.

One thread makes every layer's geometries, one layer after the other, as
the writer writes them: the memory they took in that thread's heap (glibc
gives each thread an arena of its own) then serves the next layer. A sink
may hold many geometries before it writes them: a GeoPackage layer given as
``ogr:dbname=... table=...`` goes through QGIS's layer exporter, which
buffers 200 features; for the 1 km synthetic city's blocks, 400 MB of the
feed thread's heap. With a thread for each layer, the ground's took 450 MB
more (the whole run in one QGIS process: 3,179-3,237 MB at its peak, 2,735
MB with one thread).

The feed's thread also frees the geometries once written (the writer hands
them back): a geometry is many small C++ objects (a block's, 100 k
triangles), and one made on a thread and freed on another makes the two
threads' heaps lock each other. 1.5 M triangles in 300 multipolygons into a
GeoPackage: 1.44 s parsed and written on one thread, 2.13 s parsed on a
thread of their own and freed by the writer, 0.95-1.13 s parsed and freed
on a thread of their own.
"""

import collections
import queue
import threading

from qgis.core import QgsGeometry

#: Geometries made ahead of the writer (one a block, a footprint or a tile of the ground).
AHEAD = 16
#: Geometries written that the feed keeps a little longer, until the writer
#: surely holds no reference to them: its thread must free them last.
KEPT = 4

_END = object()


def geometry_from_wkb(wkb):
    """A :class:`QgsGeometry` from WKB bytes (QGIS 3.22 has no static ``fromWkb``)."""
    geometry = QgsGeometry()
    geometry.fromWkb(bytes(wkb))
    return geometry


class GeometryFeed:
    """The geometries of one or more layers, made in turn on a thread of its own ahead of the writer.

    Each of ``sources`` is a callable returning an iterable of WKB. The
    thread starts at once, with the first, and makes as many as
    :data:`AHEAD` geometries of a layer before the writer takes them; it
    goes on with the next source when one is exhausted, while the writer
    still writes the last geometries of that one. The writer takes the
    layers in order (:meth:`layer`; iterating over the feed takes the
    first); an error of a source is raised in the writer's thread, where it
    takes that layer's next item. The writer hands each geometry back once
    written (:meth:`written`). As a context manager, leaving stops the
    thread, whether the writer took every item or failed.
    """

    def __init__(self, *sources):
        self._queues = [queue.Queue(maxsize=AHEAD) for _ in sources]
        self._written = collections.deque()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._make, args=(sources,), name="urbanvox-geometries",
                                        daemon=True)
        self._thread.start()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def close(self):
        """Stop making geometries, and wait for the thread (which frees the last ones)."""
        self._stop.set()
        self._thread.join()

    def __iter__(self):
        return self.layer(0)

    def layer(self, index):
        """The geometries of source ``index``, in order (the layers before it taken first)."""
        pending = self._queues[index]
        while True:
            item = pending.get()
            if item is _END:
                return
            if isinstance(item, BaseException):
                raise item
            yield item

    def written(self, geometry):
        """Hand back a geometry the sink has written, for this feed's thread to free."""
        self._written.append(geometry)

    def _make(self, sources):
        try:
            for source, pending in zip(sources, self._queues):
                try:
                    for wkb in source():
                        if not self._put(pending, geometry_from_wkb(wkb)):
                            return
                except BaseException as exc:  # raised in the writer's thread, which would wait forever otherwise
                    self._put(pending, exc)
                    return
                if not self._put(pending, _END):
                    return
        finally:
            # Free what the writer hands back until it leaves, then the rest.
            while not self._stop.wait(0.05):
                self._free()
            self._written.clear()

    def _put(self, pending, item):
        """Queue ``item`` in ``pending`` unless the writer has left; whether it was queued."""
        while not self._stop.is_set():
            self._free()
            try:
                pending.put(item, timeout=0.05)
                return True
            except queue.Full:
                continue
        return False

    def _free(self):
        while len(self._written) > KEPT:
            self._written.popleft()
