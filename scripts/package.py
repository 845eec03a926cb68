"""Build the installable plugin zip: dist/urbanvox-VERSION.zip with ``urbanvox/`` at its top.

What QGIS needs and nothing else: the plugin's own files as git tracks them (metadata,
``__init__.py``, ``processing_provider/``, ``core/``, ``icons/``, ``i18n/``, README, licence),
without tests, benchmarks, scripts, CI or build files. Usage: ``python3 scripts/package.py``.
"""
import configparser
import subprocess
import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
INCLUDE = ("metadata.txt", "__init__.py", "README.md", "LICENSE", "requirements.txt",
           "processing_provider/", "core/", "icons/", "i18n/", "docs/")


def plugin_files() -> list[str]:
    tracked = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True)
    files = [f for f in tracked.stdout.splitlines() if f.startswith(INCLUDE) or f in INCLUDE]
    # Compiled translations are build products (not tracked): ship them when present.
    files += [str(p.relative_to(ROOT)) for p in (ROOT / "i18n").glob("*.qm")]
    return sorted(set(files))


def main() -> int:
    meta = configparser.ConfigParser(interpolation=None)
    meta.read(ROOT / "metadata.txt", encoding="utf-8")
    version = meta["general"]["version"]
    out = ROOT / "dist" / f"urbanvox-{version}.zip"
    out.parent.mkdir(exist_ok=True)
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as archive:
        for name in plugin_files():
            archive.write(ROOT / name, f"urbanvox/{name}")
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
