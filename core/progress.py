"""How long work reports progress and learns it is cancelled.

Every step of the method that takes time accepts ``progress(fraction,
message)`` (:data:`Progress`) and ``is_cancelled()`` (:data:`CancelCheck`):
the command line prints the messages, QGIS shows them in its Processing
dialog. QGIS shows them in the user's language, but the core knows no
translator (it imports no QGIS); so a message made of parts is a :class:`Text`,
which keeps its template and parts for the host to translate, and a message
of one part is a plain constant string, which the host translates as it is.
The warnings most runs give are :class:`Text` too. ``scripts/i18n.py``
collects both kinds from the source.
"""
from __future__ import annotations

import threading
from typing import Callable

from .errors import Cancelled

#: ``progress(fraction, message)``: the share of the work done (0 to 1) and
#: what is being done (a constant string or a :class:`Text`).
Progress = Callable[[float, str], None]

#: ``is_cancelled()``: whether the user asked to stop; work then raises
#: :class:`core.errors.Cancelled` at its next check.
CancelCheck = Callable[[], bool]


def check_cancel(is_cancelled: CancelCheck | None) -> None:
    """Raise :class:`core.errors.Cancelled` if ``is_cancelled`` (optional) says so."""
    if is_cancelled is not None and is_cancelled():
        raise Cancelled()


def cancel_checked(out, is_cancelled: CancelCheck | None):
    """``out`` (a file), or where there is a cancel check, a file whose every
    write checks it first (:class:`core.errors.Cancelled` instead of writing).

    Examples
    --------
    >>> import io
    >>> out = cancel_checked(io.BytesIO(), lambda: True)
    >>> out.write(b"rows")
    Traceback (most recent call last):
    ...
    core.errors.Cancelled: Cancelled by the user; no output was written.
    """
    return out if is_cancelled is None else _CancelCheckedFile(out, is_cancelled)


class _CancelCheckedFile:
    def __init__(self, out, is_cancelled: CancelCheck):
        self.out, self.is_cancelled = out, is_cancelled

    def write(self, data) -> int:
        check_cancel(self.is_cancelled)
        return self.out.write(data)


class Text(str):
    """A progress message made of a template and its parts: a ``str`` equal
    to ``template.format(*parts)`` that keeps both, so that a host with a
    translator can translate the template and the parts that are texts.

    Parameters
    ----------
    template : str
        The message with ``{}`` for each part; a constant, so that it can be
        collected for translation.
    *parts
        The numbers and texts put in; a part that is a text is translated too
        (:meth:`translated`), a nested :class:`Text` part by part.

    Examples
    --------
    >>> text = Text("Tile {}/{}: {}", 2, 6, "Building blocks")
    >>> text
    'Tile 2/6: Building blocks'
    >>> (text.template, text.parts)
    ('Tile {}/{}: {}', (2, 6, 'Building blocks'))
    >>> french = {"Tile {}/{}: {}": "Tuile {}/{} : {}", "Building blocks": "Îlots bâtis"}
    >>> text.translated(lambda s: french.get(s, s))
    'Tuile 2/6 : Îlots bâtis'
    """

    template: str
    parts: tuple

    def __new__(cls, template: str, *parts) -> "Text":
        text = super().__new__(cls, template.format(*parts))
        text.template = template
        text.parts = parts
        return text

    def __reduce__(self):
        # Pickled as its template and parts (a tile's message may cross
        # processes): str's own pickling would make the whole text the template.
        return (Text, (self.template, *self.parts))

    def translated(self, translate: Callable[[str], str]) -> str:
        """The message with its template and text parts passed through ``translate``."""
        return translate(self.template).format(*(translated(part, translate) if isinstance(part, str) else part
                                                 for part in self.parts))


def part(progress: Progress | None, start: float, end: float, label: str | None = None) -> Progress | None:
    """``progress`` for a part of the work that spans ``start`` to ``end`` of
    the whole: the part reports its own fractions, 0 to 1. With a ``label``,
    its messages say which part they are of (``Text("{}: {}", label,
    message)``). None stays None.

    Examples
    --------
    >>> seen = []
    >>> planes = part(lambda f, m: seen.append((round(f, 3), m)), 0.4, 0.6, "Projecting block nodes")
    >>> planes(0.5, "moving-least-squares planes")
    >>> seen
    [(0.5, 'Projecting block nodes: moving-least-squares planes')]
    """
    if progress is None:
        return None

    def report(fraction: float, message: str) -> None:
        progress(start + (end - start) * min(max(fraction, 0.0), 1.0),
                 message if label is None else Text("{}: {}", label, message))
    return report


def part_with_message(progress: Progress | None, start: float, end: float,
                      message: str) -> Callable[[float], None] | None:
    """``report(share)`` for a part of the work that spans ``start`` to
    ``end`` of the whole and says one ``message`` throughout (its share done
    is all it knows). None stays None.

    Examples
    --------
    >>> seen = []
    >>> passes = part_with_message(lambda f, m: seen.append((round(f, 3), m)), 0.1, 0.2, "Eliminating")
    >>> passes(0.5)
    >>> seen
    [(0.15, 'Eliminating')]
    """
    report = part(progress, start, end)
    return None if report is None else lambda share: report(share, message)


def counted(report: Callable[[float], None] | None, total: int) -> Callable[[int], None] | None:
    """``done(count)`` for threads that each finish some of ``total`` items
    (blocks of rows on the pool's threads): ``report(share)`` with the share
    of them finished so far, one thread at a time, so the bar never goes
    back. None without ``report`` or items.

    Examples
    --------
    >>> seen = []
    >>> done = counted(seen.append, 4)
    >>> done(1); done(3)
    >>> seen
    [0.25, 1.0]
    """
    if report is None or total <= 0:
        return None
    lock = threading.Lock()
    finished = 0

    def done(count: int) -> None:
        nonlocal finished
        with lock:
            finished += count
            report(finished / total)
    return done


def translated(message: str, translate: Callable[[str], str]) -> str:
    """``message`` in the language of ``translate`` (a function from an English
    text to its translation, the text itself when it has none): a :class:`Text`
    part by part, any other string whole.

    Examples
    --------
    >>> translated("Building blocks", {"Building blocks": "Îlots bâtis"}.get)
    'Îlots bâtis'
    """
    if isinstance(message, Text):
        return message.translated(translate)
    return translate(str(message))
