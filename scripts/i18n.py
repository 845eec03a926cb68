"""Translations of the plugin's user-visible strings (Qt Linguist .ts files in i18n/).

    .venv/bin/python scripts/i18n.py update   # collect the strings (needs QGIS), merge into i18n/*.ts
    lrelease i18n/urbanvox_fr.ts -qm i18n/urbanvox_fr.qm    # what `make` does for every .ts

Strings are collected by running the algorithms' text methods with ``tr`` recorded (many are
built from tables, which a source scanner would miss), and from the source (:func:`source_strings`):
the texts the algorithms pass to ``tr`` while they run, and the core's progress messages, which
the algorithms translate as they show them (``core.progress``). Existing translations are kept;
new strings are added as unfinished, strings no longer used are dropped.
"""
import ast
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CONTEXT = "urbanvox"
LANGUAGES = ("fr", "de")


def collect() -> list[str]:
    """Every string the plugin passes to its translator, in order of first use."""
    sys.path.insert(0, str(ROOT / ".build" / "plugins"))
    from qgis.core import QgsApplication

    app = QgsApplication([], False)
    app.initQgis()
    from urbanvox.processing_provider import provider as provider_module
    from urbanvox.processing_provider.algorithms import base

    seen: list[str] = []

    def record(text: str) -> str:
        if text not in seen:
            seen.append(text)
        return text

    base.UrbanvoxAlgorithm.tr = lambda self, text: record(text)
    provider_module.tr = record
    provider = provider_module.UrbanvoxProvider()
    provider.longName()
    provider.loadAlgorithms()
    for algorithm in provider.algorithms():
        algorithm = algorithm.create()
        algorithm.displayName()
        algorithm.shortHelpString()
        algorithm.tags()
    return seen


def source_strings() -> list[str]:
    """The constant texts of the source that reach the translator while an algorithm runs:
    ``tr("...")`` in processing_provider/, and in core/ the messages given to ``report`` or
    ``progress`` as constants, the templates of ``Text("...", ...)`` (core.progress: progress
    texts and the warnings most runs give), the labels given to ``part``, the messages given to
    ``part_with_message`` and the parts given to ``report_part`` (core.project). Needs no QGIS."""
    found: list[str] = []
    for folder, wanted in (("processing_provider", _provider_text), ("core", _progress_text)):
        for path in sorted((ROOT / folder).rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
                text = wanted(node) if isinstance(node, ast.Call) else None
                if text is not None and text not in found:
                    found.append(text)
    return found


def _name(call: ast.Call) -> str | None:
    function = call.func
    return function.attr if isinstance(function, ast.Attribute) else getattr(function, "id", None)


def _constant(node: ast.expr) -> str | None:
    return node.value if isinstance(node, ast.Constant) and isinstance(node.value, str) else None


def _provider_text(call: ast.Call) -> str | None:
    return _constant(call.args[0]) if _name(call) == "tr" and call.args else None


def _progress_text(call: ast.Call) -> str | None:
    if _name(call) in ("Text", "report_part") and call.args:  # a template; a part of core.project's projection
        return _constant(call.args[0])
    if _name(call) in ("report", "progress") and len(call.args) >= 2:
        return _constant(call.args[1])
    if _name(call) == "part_with_message" and len(call.args) >= 4:  # core.progress's
        return _constant(call.args[3])
    if _name(call) == "part":  # core.progress.part's label
        keywords = {k.arg: k.value for k in call.keywords}
        label = call.args[3] if len(call.args) >= 4 else keywords.get("label")
        return None if label is None else _constant(label)
    return None


def read_ts(path: Path) -> dict[str, str]:
    if not path.exists():
        return {}
    translations = {}
    for message in ET.parse(path).getroot().iter("message"):
        translation = message.find("translation")
        if translation is not None and translation.text and translation.get("type") != "unfinished":
            translations[message.find("source").text] = translation.text
    return translations


def write_ts(path: Path, language: str, strings: list[str], translations: dict[str, str]) -> None:
    ts = ET.Element("TS", version="2.1", language=language)
    context = ET.SubElement(ts, "context")
    ET.SubElement(context, "name").text = CONTEXT
    for text in strings:
        message = ET.SubElement(context, "message")
        ET.SubElement(message, "source").text = text
        translation = ET.SubElement(message, "translation")
        if text in translations:
            translation.text = translations[text]
        else:
            translation.set("type", "unfinished")
    ET.indent(ts)
    path.write_text('<?xml version="1.0" encoding="utf-8"?>\n<!DOCTYPE TS>\n'
                    + ET.tostring(ts, encoding="unicode") + "\n", encoding="utf-8")


def main(argv: list[str]) -> int:
    if argv[:1] != ["update"]:
        print(__doc__)
        return 2
    strings = collect()
    strings += [text for text in source_strings() if text not in strings]
    for language in LANGUAGES:
        path = ROOT / "i18n" / f"urbanvox_{language}.ts"
        translations = read_ts(path)
        write_ts(path, language, strings, translations)
        missing = [s for s in strings if s not in translations]
        print(f"{path.name}: {len(strings)} strings, {len(missing)} to translate")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
