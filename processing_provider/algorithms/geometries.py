"""The output layers' geometries, made on threads of their own ahead of the writer.

A layer's features take three steps: the core writes the WKB of each
geometry (numpy, :mod:`core.wkb`), QGIS parses it into a
:class:`QgsGeometry`, and the sink writes that. The first two run on a
thread of its own for each layer (:class:`GeometryFeed`) while the
algorithm's thread writes: the parse and the sink's write run in QGIS's C++
with the GIL released.

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
    """The geometries of one layer, made on a thread of its own ahead of the writer.

    ``source`` is a callable returning an iterable of WKB. The thread starts
    at once and parses as many as :data:`AHEAD` of them before the writer
    iterates over the feed; an error of the source is raised in the writer's
    thread, where it takes the next item. The writer hands each geometry
    back once written (:meth:`written`). As a context manager, leaving
    stops the thread, whether the writer took every item or failed.
    """

    def __init__(self, source):
        self._queue = queue.Queue(maxsize=AHEAD)
        self._written = collections.deque()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._make, args=(source,), name="urbanvox-geometries",
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
        while True:
            item = self._queue.get()
            if item is _END:
                return
            if isinstance(item, BaseException):
                raise item
            yield item

    def written(self, geometry):
        """Hand back a geometry the sink has written, for this feed's thread to free."""
        self._written.append(geometry)

    def _make(self, source):
        try:
            for wkb in source():
                if not self._put(geometry_from_wkb(wkb)):
                    return
            self._put(_END)
        except BaseException as exc:  # raised in the writer's thread, which would wait forever otherwise
            self._put(exc)
        finally:
            # Free what the writer hands back until it leaves, then the rest.
            while not self._stop.wait(0.05):
                self._free()
            self._written.clear()

    def _put(self, item):
        """Queue ``item`` unless the writer has left; whether it was queued."""
        while not self._stop.is_set():
            self._free()
            try:
                self._queue.put(item, timeout=0.05)
                return True
            except queue.Full:
                continue
        return False

    def _free(self):
        while len(self._written) > KEPT:
            self._written.popleft()
