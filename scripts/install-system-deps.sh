#!/usr/bin/env bash
# Install QGIS (with its Python bindings and qgis_process), python3-venv and xvfb from the
# distribution (Debian/Ubuntu), only when something is missing. Uses sudo when not root.
set -euo pipefail

PACKAGES=(qgis python3-qgis qgis-providers python3-venv python3-pip xvfb qttools5-dev-tools)

missing=()
command -v qgis_process.bin >/dev/null 2>&1 || missing+=(qgis_process.bin)
/usr/bin/python3 -c 'import qgis.core, processing' >/dev/null 2>&1 \
  || PYTHONPATH=/usr/share/qgis/python/plugins /usr/bin/python3 -c 'import qgis.core, processing' >/dev/null 2>&1 \
  || missing+=(python3-qgis)
/usr/bin/python3 -c 'import ensurepip' >/dev/null 2>&1 || missing+=(python3-venv)
command -v Xvfb >/dev/null 2>&1 || missing+=(xvfb)
command -v lrelease >/dev/null 2>&1 || missing+=(lrelease)

if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi
echo "Missing: ${missing[*]}; installing ${PACKAGES[*]} with apt-get." >&2
if ! command -v apt-get >/dev/null 2>&1; then
  echo "No apt-get here: install QGIS >= 3.22 with its Python bindings, python3-venv and xvfb yourself." >&2
  exit 1
fi
SUDO=()
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null 2>&1 || { echo "Not root and no sudo: install ${PACKAGES[*]} as root." >&2; exit 1; }
  SUDO=(sudo)
fi
export DEBIAN_FRONTEND=noninteractive
"${SUDO[@]}" env DEBIAN_FRONTEND=noninteractive apt-get update
"${SUDO[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y "${PACKAGES[@]}"
