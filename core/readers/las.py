"""Read classified LiDAR points (LAS/LAZ) as ground and building point sets (paper §2).

The method only needs "a segmentation of the points into ground and other points"
(§2). Airborne LiDAR deliveries carry that segmentation as ASPRS class codes: the
user says which codes are ground (default 2) and which are building (default 6);
every other point (vegetation, noise, water, unclassified, vendor codes such as
AHN's 26 or IGN's 64/208/214) is ignored rather than risk turning trees into
buildings.

Files are streamed in chunks so a large tile collection never needs more memory
than the kept points, and the user can cancel between chunks.

Example
-------
>>> import tempfile, os, laspy, numpy as np, pyproj
>>> las = laspy.LasData(laspy.LasHeader(version="1.4", point_format=6))
>>> las.header.scales = [0.01, 0.01, 0.01]
>>> las.x = np.array([0.0, 1.0, 2.0]); las.y = np.zeros(3); las.z = np.array([0.0, 0.0, 5.0])
>>> las.classification = np.array([2, 2, 6], dtype=np.uint8)
>>> las.header.add_crs(pyproj.CRS("EPSG:28992"))
>>> path = os.path.join(tempfile.mkdtemp(), "tiny.las"); las.write(path)
>>> pts = read_point_clouds(path)
>>> pts.ground.shape, pts.building.shape, pts.crs.to_epsg(), pts.class_counts
((2, 3), (1, 3), 28992, {2: 2, 6: 1})
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Callable, Dict, List, Optional, Sequence, Tuple, Union

import laspy
import numpy as np
import pyproj

from .. import jit
from ..crs import describe_crs, horizontal_crs, resolve_crs
from ..errors import Cancelled, UrbanvoxError
from ..heap import reusing_freed_memory, use_array_heap_here
from ..vectors import all_finite, finite_rows

__all__ = ["LabelledPoints", "parse_classes", "read_point_clouds", "CLASS_NAMES", "CHUNK_POINTS"]

PathLike = Union[str, "os.PathLike[str]"]

#: Points decoded per chunk: bounds memory (~100 MB of raw records) and sets how
#: often cancellation is checked. Module-level so tests can shrink it.
CHUNK_POINTS = 2_000_000

#: ASPRS LAS 1.4 R15 standard class codes (23-63 reserved, 64-255 user defined).
CLASS_NAMES: Dict[int, str] = {
    0: "never classified", 1: "unclassified", 2: "ground", 3: "low vegetation",
    4: "medium vegetation", 5: "high vegetation", 6: "building", 7: "low point (noise)",
    8: "reserved / model key", 9: "water", 10: "rail", 11: "road surface", 12: "reserved / overlap",
    13: "wire guard", 14: "wire conductor", 15: "transmission tower", 16: "wire connector",
    17: "bridge deck", 18: "high noise", 19: "overhead structure", 20: "ignored ground",
    21: "snow", 22: "temporal exclusion",
}

# Only the fields we use are decompressed from LAZ 1.4 (point formats 6-10 store
# them in separate layers), which makes reading several times faster.
_LAZ_FIELDS = (
    laspy.DecompressionSelection.XY_RETURNS_CHANNEL
    | laspy.DecompressionSelection.Z
    | laspy.DecompressionSelection.CLASSIFICATION
    | laspy.DecompressionSelection.FLAGS
)

# Record ids of the LASF_Projection VLRs: WKT (2112) and GeoTIFF keys (34735).
_CRS_RECORD_IDS = (2111, 2112, 34735, 34736, 34737)


@dataclass
class LabelledPoints:
    """Ground and building points of one or several LAS/LAZ files.

    Attributes
    ----------
    ground, building : numpy.ndarray
        (G, 3) and (B, 3) float64 world coordinates (scaled LAS coordinates).
    crs : pyproj.CRS
        CRS shared by all files (header or CRS parameter).
    class_counts : dict
        Every class code present in the files -> number of points (all files).
    n_points : int
        Total number of points read (all classes).
    warnings : list of str
        Things the user should know but that do not stop the run.
    """

    ground: np.ndarray
    building: np.ndarray
    crs: pyproj.CRS
    class_counts: Dict[int, int]
    n_points: int
    warnings: List[str] = field(default_factory=list)


def class_label(code: int) -> str:
    """``"6 (building)"``, ``"26 (non-standard)"``: a class code for messages."""
    name = CLASS_NAMES.get(int(code))
    if name is None:
        name = "reserved, non-standard" if code < 64 else "user-defined, non-standard"
    return f"{int(code)} ({name})"


def parse_classes(text: Union[str, Sequence[int]], parameter: str = "class") -> Tuple[int, ...]:
    """Parse a list of class codes given as text or integers.

    Parameters
    ----------
    text : str or sequence of int
        ``"2"``, ``"2,9"``, ``"2 9"``, ``"2; 9"`` or ``[2, 9]``.
    parameter : str
        Parameter name used in error messages (e.g. ``"GROUND_CLASSES"``).

    Returns
    -------
    tuple of int
        Codes in the order given, duplicates removed.

    Raises
    ------
    UrbanvoxError
        Empty list, non-integer text or a code outside 0-255.

    Example
    -------
    >>> parse_classes("2, 9"), parse_classes("6"), parse_classes([2, 9, 2])
    ((2, 9), (6,), (2, 9))
    """
    if isinstance(text, str):
        tokens = text.replace(",", " ").replace(";", " ").split()
    else:
        tokens = list(text)
    codes: List[int] = []
    for token in tokens:
        try:
            value = int(str(token).strip())
            if isinstance(token, float) and token != value:  # 2.5 is not a class code
                raise ValueError(token)
        except ValueError:
            raise UrbanvoxError(
                f"The {parameter} parameter {text!r} is not a list of class codes; "
                "write integers separated by commas or spaces, e.g. '2' or '2,9'."
            ) from None
        if not 0 <= value <= 255:
            raise UrbanvoxError(
                f"The {parameter} parameter contains {value}, but LAS class codes are 0-255; "
                "fix the list (e.g. '2' for ground, '6' for building)."
            )
        if value not in codes:
            codes.append(value)
    if not codes:
        raise UrbanvoxError(f"The {parameter} parameter is empty; give at least one class code, e.g. '2'.")
    return tuple(codes)


def _as_path_list(paths: Union[PathLike, Sequence[PathLike]]) -> List[str]:
    if isinstance(paths, (str, os.PathLike)):
        paths = [paths]
    out = [os.fspath(p) for p in paths]
    if not out:
        raise UrbanvoxError("No point cloud file was given; choose one or more LAS/LAZ files.")
    return out


def _open(path: str) -> "laspy.LasReader":
    """Open a LAS/LAZ file, turning every failure into an actionable message."""
    if not os.path.exists(path):
        raise UrbanvoxError(f"Point cloud file {path} does not exist; check the path.")
    if os.path.isdir(path):
        raise UrbanvoxError(f"{path} is a folder, not a LAS/LAZ file; choose the .las/.laz files inside it.")
    try:
        return laspy.open(path, decompression_selection=_LAZ_FIELDS)
    except Exception as exc:  # laspy, lazrs (LazrsError), OSError, ... on bad or truncated files
        raise UrbanvoxError(
            f"{path} cannot be read as a LAS/LAZ point cloud ({exc}); check that it is a valid "
            "LAS 1.0-1.4 or LAZ file (e.g. open it with QGIS or 'pdal info')."
        ) from exc


def _header_crs(header: "laspy.LasHeader", path: str, warnings: List[str]) -> Optional[pyproj.CRS]:
    """CRS declared in the header (WKT preferred over GeoTIFF keys), or None."""
    try:
        crs = header.parse_crs()
    except Exception as exc:  # laspy/pyproj raise several types on malformed records
        crs = None
        warnings.append(f"{os.path.basename(path)}: the CRS record in the header cannot be parsed ({exc}).")
    if crs is None and any(
        vlr.user_id.strip("\0") == "LASF_Projection" and vlr.record_id in _CRS_RECORD_IDS
        for vlr in list(header.vlrs) + list(getattr(header, "evlrs", None) or [])
    ):
        warnings.append(
            f"{os.path.basename(path)} has a CRS record that could not be interpreted; "
            "it is treated as having no CRS."
        )
    return crs


def _collection_crs(
    paths: List[str], header_crss: List[Optional[pyproj.CRS]], override: Optional[str], warnings: List[str]
) -> pyproj.CRS:
    """One CRS for a tile collection: override, else the headers' (which must agree)."""
    has_override = override is not None and str(override).strip() != ""
    first: Optional[Tuple[str, pyproj.CRS]] = None
    for path, crs in zip(paths, header_crss):
        if crs is None:
            continue
        if first is None:
            first = (path, crs)
            continue
        # Compare horizontal parts: 2154 and 2154+5720 tiles can be mixed.
        same = horizontal_crs(crs).equals(horizontal_crs(first[1]), ignore_axis_order=True)
        if not same and not has_override:  # with an override, the loop below warns instead
            raise UrbanvoxError(
                f"The point cloud files do not share one CRS: {first[0]} is {describe_crs(first[1])} but "
                f"{path} is {describe_crs(crs)}. Reproject the tiles to one CRS (e.g. with PDAL), or, if "
                "a header is wrong, set the CRS parameter to the CRS of the coordinates."
            )
    source = paths[0] if len(paths) == 1 else f"{paths[0]} (and the {len(paths) - 1} other files)"
    resolved = resolve_crs(first[1] if first else None, override, source)
    if has_override:
        for path, crs in zip(paths, header_crss):
            same = crs is None or horizontal_crs(crs).equals(horizontal_crs(resolved), ignore_axis_order=True)
            if not same:
                warnings.append(
                    f"{os.path.basename(path)} declares {describe_crs(crs)} in its header; "
                    f"the CRS parameter {describe_crs(resolved)} is used instead."
                )
    elif first is not None:
        missing = [os.path.basename(p) for p, c in zip(paths, header_crss) if c is None]
        if missing:
            warnings.append(
                f"{len(missing)} file(s) have no CRS in their header ({', '.join(missing[:5])}); "
                f"assumed to be {describe_crs(resolved)} like {os.path.basename(first[0])}."
            )
    return resolved


class _Rows:
    """Points (n, 3) written chunk by chunk into one table as long as the
    files' points, trimmed in place at the end (``ndarray.resize``: a
    ``realloc`` that keeps the start). The chunks' own arrays joined by
    ``np.concatenate`` held every point twice at the end of the read, and
    their copy faulted in fresh memory for all of them: 3.3 of the 12.4 s
    of reading the 2 km synthetic city's 50 M points. The table's pages are
    only touched where points are written."""

    def __init__(self, most: int):
        self.table = np.empty((most, 3), dtype=np.float64)
        self.n = 0

    def room(self, count: int) -> np.ndarray:
        """The rows after the last written, at least ``count`` of them; :meth:`next`
        gives them as written."""
        if self.n + count > len(self.table):  # a header that counts fewer points than its file holds
            grown = np.empty((max(2 * len(self.table), self.n + count), 3), dtype=np.float64)
            grown[:self.n] = self.table[:self.n]
            self.table = grown
        return self.table[self.n:]

    def next(self, count: int) -> np.ndarray:
        """The next ``count`` rows, to be written."""
        rows = self.room(count)[:count]
        self.n += count
        return rows

    def keep_last(self, keep: np.ndarray) -> None:
        """Keep only the rows ``keep`` (a mask) of the rows last given by :meth:`next`."""
        start = self.n - len(keep)
        kept = self.table[start:self.n].compress(keep, axis=0)
        self.table[start:start + len(kept)] = kept
        self.n = start + len(kept)

    def result(self) -> np.ndarray:
        """The rows written, as an array of their own."""
        table, self.table = self.table, np.empty((0, 3))
        table.resize((self.n, 3), refcheck=False)
        return table


#: What a class code's points are: kept as ground, as building, or not kept.
NOT_KEPT, GROUND, BUILDING = 0, 1, 2


def point_kinds(ground_codes: np.ndarray, building_codes: np.ndarray) -> np.ndarray:
    """A table of 256 entries: what the points of each class code are.

    Examples
    --------
    >>> point_kinds(np.array([2]), np.array([6, 7]))[[1, 2, 6, 7]].tolist()
    [0, 1, 2, 2]
    """
    table = np.full(256, NOT_KEPT, dtype=np.uint8)
    table[np.asarray(building_codes, dtype=np.uint8)] = BUILDING
    table[np.asarray(ground_codes, dtype=np.uint8)] = GROUND
    return table


def field_bits(field) -> Tuple[np.ndarray, int, int]:
    """A point field as the bytes that hold it, its bit mask and its shift.

    laspy gives a field that shares its byte with others (the withheld flag;
    the class code in point formats 0-5) as a ``SubFieldView`` of that byte;
    the compiled reader (:mod:`core.las_kernel`) takes the byte and the bits
    rather than a new array of the values.

    Examples
    --------
    >>> from laspy.point.dims import SubFieldView
    >>> bits = field_bits(SubFieldView(np.array([0b10100011], np.uint8), 0b00011111))
    >>> bits[0].tolist(), bits[1:]
    ([163], (31, 0))
    >>> field_bits(np.array([6, 2], np.uint8))[1:]
    (255, 0)
    """
    from laspy.point.dims import SubFieldView

    if isinstance(field, SubFieldView) and field.array.dtype == np.uint8:
        return field.array, int(field.bit_mask), int(field.lsb)
    return np.asarray(field, dtype=np.uint8), 0xFF, 0


def _read_file(
    reader: "laspy.LasReader",
    path: str,
    ground_codes: np.ndarray,
    building_codes: np.ndarray,
    counts: np.ndarray,
    ground_rows: "_Rows",
    building_rows: "_Rows",
    is_cancelled: Optional[Callable[[], bool]],
    chunk_read: Optional[Callable[[int], None]] = None,
) -> Tuple[int, int, int]:
    """Stream one file; append kept points; return (points read, non-finite, withheld).
    ``chunk_read(n)`` is told the points of every chunk once they are kept."""
    header = reader.header
    scales = np.asarray(header.scales, dtype=np.float64)
    offsets = np.asarray(header.offsets, dtype=np.float64)
    if (scales == 0).any():
        # Every point at the offset on that axis: a corrupt header, which
        # would give a silently wrong model.
        raise UrbanvoxError(
            f"{path}: the header's scales {scales.tolist()} include zero, so every coordinate "
            "on that axis is the same; the header is corrupt: repair the file (e.g. 'pdal translate' with "
            "explicit scale/offset) and try again.")
    kind = point_kinds(ground_codes, building_codes)
    # x * scale + offset of an int32 x is finite for every x when the largest
    # magnitude it can reach is: then no chunk needs a look for NaN or inf.
    may_be_non_finite = not np.isfinite(2.0**31 * np.abs(scales) + np.abs(offsets)).all()
    n_read = n_bad = n_withheld = 0
    try:
        for chunk in reader.chunk_iterator(CHUNK_POINTS):
            if is_cancelled is not None and is_cancelled():
                raise Cancelled()
            n_read += len(chunk)
            # Compiled where the kernels are loaded already (read_point_clouds
            # starts loading them): the same rows, in one pass.
            written = None
            if jit.ready("las_kernel"):
                chunk_counts = np.zeros(256, dtype=np.int64)
                flags, withheld_mask, _ = field_bits(chunk.withheld)  # a flag: no shift to undo
                written = jit.run("las_kernel", "split_chunk", np.asarray(chunk.X), np.asarray(chunk.Y),
                                  np.asarray(chunk.Z), *field_bits(chunk.classification), flags, withheld_mask,
                                  kind, scales, offsets, chunk_counts,
                                  ground_rows.room(len(chunk)), building_rows.room(len(chunk)))
            if written is not None:
                n_ground, n_building, withheld_here = written
                counts += chunk_counts
                n_withheld += withheld_here
                new_rows = [(ground_rows.next(n_ground), ground_rows),
                            (building_rows.next(n_building), building_rows)]
            else:
                cls = np.asarray(chunk.classification, dtype=np.uint8)
                counts += np.bincount(cls, minlength=256)
                # Withheld points are to be deleted per the LAS spec (they stay counted).
                withheld = np.asarray(chunk.withheld, dtype=bool)
                n_withheld += int(withheld.sum())
                keep = ~withheld
                new_rows = []
                for mask, rows in ((np.isin(cls, ground_codes) & keep, ground_rows),
                                   (np.isin(cls, building_codes) & keep, building_rows)):
                    # Scale only the kept points; float64 keeps the header's precision.
                    xyz = rows.next(int(mask.sum()))
                    # compress: 2.5 times faster than indexing with a mask (core.vectors).
                    xyz[:, 0] = np.asarray(chunk.X).compress(mask) * scales[0] + offsets[0]
                    xyz[:, 1] = np.asarray(chunk.Y).compress(mask) * scales[1] + offsets[1]
                    xyz[:, 2] = np.asarray(chunk.Z).compress(mask) * scales[2] + offsets[2]
                    new_rows.append((xyz, rows))
            for xyz, rows in new_rows:
                if may_be_non_finite and len(xyz) and not all_finite(xyz):
                    finite = finite_rows(xyz)
                    n_bad += int((~finite).sum())
                    rows.keep_last(finite)
            if chunk_read is not None:
                chunk_read(len(chunk))
    except UrbanvoxError:
        raise
    except Exception as exc:  # lazrs / laspy decoding errors on truncated or corrupt data
        raise UrbanvoxError(
            f"{path} is damaged: reading stopped after {n_read} points ({exc}); re-download or "
            "repair the file (e.g. 'pdal translate' or LAStools 'laszip')."
        ) from exc
    return n_read, n_bad, n_withheld


# The chunks' temporaries and the joined arrays reuse freed memory (core.heap):
# with fresh pages for each, reading the 1 km city's 12.5 M points took 2.9 s
# instead of 2.0 s (decoding 1.3 s).
@reusing_freed_memory()
def read_point_clouds(
    paths: Union[PathLike, Sequence[PathLike]],
    ground_classes: Union[str, Sequence[int]] = (2,),
    building_classes: Union[str, Sequence[int]] = (6,),
    crs: Optional[str] = None,
    is_cancelled: Optional[Callable[[], bool]] = None,
    progress: Optional[Callable[[float, str], None]] = None,
) -> LabelledPoints:
    """Read ground and building points from one or several LAS/LAZ files.

    Parameters
    ----------
    paths : path or sequence of paths
        LAS/LAZ files (LAS 1.0-1.4, any point format). Several files form one
        tile collection and must share one CRS.
    ground_classes, building_classes : str or sequence of int
        Class codes of ground and of buildings (see :func:`parse_classes`).
        A code may not be in both. ``building_classes`` may be empty.
    crs : str, optional
        CRS parameter; overrides the headers (see :func:`core.crs.resolve_crs`).
    is_cancelled : callable, optional
        Zero-argument callable checked between chunks; True raises :class:`Cancelled`.
    progress : callable, optional
        ``progress(fraction, message)``, told the share of the points read after every chunk.

    Returns
    -------
    LabelledPoints

    Raises
    ------
    UrbanvoxError
        Missing/unreadable file, empty file, no/invalid/geographic CRS, CRS
        mismatch between files, overlapping class lists, or no ground point.

    Example
    -------
    >>> pts = read_point_clouds(["a.laz", "b.laz"], "2", "6", crs="EPSG:2154")  # doctest: +SKIP
    """
    files = _as_path_list(paths)
    ground = parse_classes(ground_classes, "GROUND_CLASSES")
    # An empty building list is allowed: the result is ground only (with a warning).
    if isinstance(building_classes, str):
        no_building = building_classes.strip() == ""
    else:
        no_building = len(building_classes) == 0
    building = () if no_building else parse_classes(building_classes, "BUILDING_CLASSES")
    overlap = sorted(set(ground) & set(building))
    if overlap:
        raise UrbanvoxError(
            f"Class code(s) {overlap} are in both GROUND_CLASSES {list(ground)} and BUILDING_CLASSES "
            f"{list(building)}; a point cannot be both, remove them from one list."
        )
    warnings: List[str] = []

    # Pass 1: headers only, so CRS problems are reported before any long read.
    header_crss: List[Optional[pyproj.CRS]] = []
    most = 0
    for path in files:
        with _open(path) as reader:
            if reader.header.point_count == 0:
                raise UrbanvoxError(f"{path} contains no points (empty LAS file); remove it from the inputs.")
            header_crss.append(_header_crs(reader.header, path, warnings))
            most += int(reader.header.point_count)
    resolved = _collection_crs(files, header_crss, crs, warnings)

    # Pass 2: stream the points. The compiled kernels load meanwhile when the
    # run will want them (core.jit.preload); the reader's own runs from the
    # chunk after it is loaded.
    jit.preload(most)
    if most >= jit.WORTHWHILE:
        # In a host's thread, a run this large makes its arrays in the array
        # heap, the points read first (core.heap).
        use_array_heap_here(load=True)
    counts = np.zeros(256, dtype=np.int64)
    ground_rows, building_rows = _Rows(most), _Rows(most)
    g_codes = np.asarray(ground, dtype=np.uint8)
    b_codes = np.asarray(building, dtype=np.uint8)
    n_points = n_bad = n_withheld = 0
    done = [0]

    def chunk_read(count: int) -> None:
        done[0] += count
        progress(done[0] / most, "Reading point cloud")

    for path in files:
        if is_cancelled is not None and is_cancelled():
            raise Cancelled()
        with _open(path) as reader:
            n, bad, withheld = _read_file(
                reader, path, g_codes, b_codes, counts, ground_rows, building_rows, is_cancelled,
                None if progress is None else chunk_read,
            )
        if n == 0:
            raise UrbanvoxError(f"{path} contains no points (empty LAS file); remove it from the inputs.")
        n_points += n
        n_bad += bad
        n_withheld += withheld

    present = np.flatnonzero(counts)
    class_counts = {int(c): int(counts[c]) for c in present}
    ground_xyz, building_xyz = ground_rows.result(), building_rows.result()
    listing = ", ".join(f"{class_label(c)}: {n}" for c, n in class_counts.items())

    if len(ground_xyz) == 0 and n_bad:
        raise UrbanvoxError(
            f"All {n_bad} ground/building points have non-finite (NaN/inf) coordinates, so the header's "
            "scale or offset is corrupt; repair the file (e.g. 'pdal translate' with explicit "
            "scale/offset) and try again."
        )
    if len(ground_xyz) == 0 and n_withheld:
        raise UrbanvoxError(
            f"No point of the ground classes {list(ground)} is left in {len(files)} file(s) once the "
            f"{n_withheld} points flagged 'withheld' (deleted, per the LAS specification) are dropped. "
            f"Classes present, withheld points included: {listing}. Clear the withheld flag of the points "
            "to keep (e.g. PDAL filters.assign), or set GROUND_CLASSES to the ground code(s) of your data."
        )
    if len(ground_xyz) == 0:
        raise UrbanvoxError(
            f"No point of the ground classes {list(ground)} was found in {len(files)} file(s). "
            f"Classes present: {listing}. Set the GROUND_CLASSES parameter to the ground code(s) of "
            "your data, or classify the ground first (e.g. PDAL filters.smrf or filters.csf)."
        )
    if n_bad:
        warnings.append(f"dropped {n_bad} points with non-finite (NaN/inf) coordinates.")
    if n_withheld:
        warnings.append(f"dropped {n_withheld} points flagged 'withheld' (deleted per the LAS specification).")
    absent = [c for c in building if c not in class_counts]
    if absent:
        warnings.append(f"building classes {absent} absent from the file(s); present: {class_counts}.")
    if len(building_xyz) == 0:
        warnings.append(
            "no building point was read, so the result will have no building block; check the "
            "BUILDING_CLASSES parameter against the classes present: " + listing + "."
        )
    kept = set(ground) | set(building)
    # Vendor codes may hide buildings (e.g. IGN 64 'permanent above-ground'), so say so.
    for c in [c for c in class_counts if c not in kept and c not in CLASS_NAMES]:
        warnings.append(f"ignored {class_counts[c]} points of class {c} (non-standard).")

    return LabelledPoints(ground_xyz, building_xyz, resolved, class_counts, n_points, warnings)
