"""Progress messages: what the core reports can be shown in the user's language.

The core imports no translator; QGIS translates its messages through the plugin's catalogs
(i18n/*.ts), which ``scripts/i18n.py`` fills from the source. These tests check that every
message a run reports reaches those catalogs translated, as it is made (template and parts).
"""
import importlib.util
import pickle
import re
import string
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from core.pipeline import ReconstructionParams, reconstruct_point_cloud
from core.progress import Text, translated
from core.tiles import TileOptions

REPO_ROOT = Path(__file__).resolve().parents[1]
LANGUAGES = ("fr", "de")


def _i18n_script():
    spec = importlib.util.spec_from_file_location("urbanvox_i18n", REPO_ROOT / "scripts" / "i18n.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _catalog(language: str) -> dict[str, str]:
    """The finished translations of i18n/urbanvox_<language>.ts."""
    return _i18n_script().read_ts(REPO_ROOT / "i18n" / f"urbanvox_{language}.ts")


def _fields(template: str) -> list[tuple]:
    """The replacement fields of a template, with their formats: ``{}``, ``{:g}``..."""
    return [(name, spec) for _, name, spec, _ in string.Formatter().parse(template) if name is not None]


def _pieces(message: str) -> list[str]:
    """The texts a message is translated by: a Text's template and its text parts, in depth."""
    if not isinstance(message, Text):
        return [str(message)]
    return [message.template] + [piece for part in message.parts if isinstance(part, str) for piece in _pieces(part)]


def test_a_text_is_its_formatted_string_and_keeps_its_parts():
    text = Text("Tile {}/{}: {}", 3, 9, Text("Smoothing ({} passes)", 3))
    assert text == "Tile 3/9: Smoothing (3 passes)" and isinstance(text, str)
    assert text.endswith("passes)") and f"{text}" == str(text)
    assert (text.template, text.parts[:2]) == ("Tile {}/{}: {}", (3, 9))
    # A tile's message may cross processes (Dask): it stays a Text, not a plain string.
    copy = pickle.loads(pickle.dumps(text))
    assert copy == text and copy.template == text.template and copy.parts[2].template == "Smoothing ({} passes)"


def test_a_text_is_translated_part_by_part_and_a_plain_string_whole():
    french = {"Tile {}/{}: {}": "Tuile {}/{} : {}", "Smoothing ({} passes)": "Lissage ({} passes)",
              "Building blocks": "Îlots bâtis"}

    def translate(text):
        return french.get(text, text)

    assert translated(Text("Tile {}/{}: {}", 3, 9, Text("Smoothing ({} passes)", 3)), translate) \
        == "Tuile 3/9 : Lissage (3 passes)"
    assert translated(Text("Tile {}/{}: {}", 1, 2, "Building blocks"), translate) == "Tuile 1/2 : Îlots bâtis"
    assert translated("Building blocks", translate) == "Îlots bâtis"
    # A part that is not in the catalog (a file name, a number) is left as it is.
    assert translated(Text("Tile {}/{}: {}", 1, 2, "roofs.laz"), translate) == "Tuile 1/2 : roofs.laz"


@pytest.mark.parametrize("language", LANGUAGES)
def test_every_text_the_source_can_show_is_translated_with_its_placeholders(language):
    collected = _i18n_script().source_strings()
    # The collector finds the kinds of texts there are: the provider's, the core's constants and templates.
    assert {"Writing the ground", "Projecting nodes onto the data", "Tile {}/{}: {}",
            "No building block in the result.", "Projecting block nodes", "face crossings"} <= set(collected)
    catalog = _catalog(language)
    missing = [text for text in collected if text not in catalog]
    assert not missing
    for text in collected:  # the same fields, with the same formats, in the same order
        assert _fields(catalog[text]) == _fields(text), (text, catalog[text])


def test_every_message_of_a_run_is_collected_and_translated(district):
    """The messages of a run, single and tiled, are all made of collected texts, and every
    one of them reads differently in French and German (so none stays English)."""
    seen = []
    params = ReconstructionParams(voxel_size=2.0, extent=district.district.extent)
    single = reconstruct_point_cloud(district.laz, params=params, progress=lambda f, m: seen.append(m))
    reconstruct_point_cloud(district.laz, params=params, tiles=TileOptions(tile_size=100.0),
                            progress=lambda f, m: seen.append(m))
    assert any(m.startswith("Tile 9/9") for m in seen) and any(re.fullmatch(r"\d+ blocks", m) for m in seen)
    collected = set(_i18n_script().source_strings())
    assert not [piece for m in seen for piece in _pieces(m) if piece not in collected]
    for language in LANGUAGES:
        catalog = _catalog(language)
        shown = {m: translated(m, lambda text: catalog.get(text, text)) for m in seen}
        assert not [m for m, text in shown.items() if text == m], language
    # The warnings the district gives (blocks below the thresholds, roof holes) are translated too.
    common = [w for w in single.warnings if isinstance(w, Text)]
    assert any(w.startswith("Dropped") for w in common) and not [w for w in common if w.template not in collected]
    french = _catalog("fr")
    assert any(translated(w, french.get).endswith("écartés (hauteur 2.5 m, emprise 10 m², volume 20 m³).")
               for w in common)
