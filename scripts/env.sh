# Environment for running QGIS against this checkout; source it (bash): `. scripts/env.sh`.
#
# Shared by the Makefile, scripts/qgis-process, the demo and the tests, so all of them see
# the same things:
#   - QGIS_CUSTOM_CONFIG_PATH: a project-local QGIS profile in .qgis/ (the user's own profile
#     is never read or written),
#   - QGIS_PLUGINPATH: .build/plugins, where `urbanvox` is a symlink to this checkout (the
#     checkout directory may have any name),
#   - PYTHONPATH: the venv's site-packages, so the Python inside qgis_process finds laspy,
#     trimesh, ... (the venv is made from /usr/bin/python3, the Python QGIS embeds),
#   - QGIS_PROCESS: the real qgis_process binary (Debian's /usr/bin/qgis_process wrapper passes
#     --noversioncheck, which QGIS 3.22 rejects); set it beforehand to use another one,
#   - QT_QPA_PLATFORM=offscreen: no display needed.

URBANVOX_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd -P)"
export URBANVOX_ROOT
export QT_QPA_PLATFORM="${QT_QPA_PLATFORM:-offscreen}"
export QGIS_CUSTOM_CONFIG_PATH="${URBANVOX_QGIS_PROFILE:-$URBANVOX_ROOT/.qgis}"

mkdir -p "$URBANVOX_ROOT/.build/plugins" "$QGIS_CUSTOM_CONFIG_PATH"
ln -sfn "$URBANVOX_ROOT" "$URBANVOX_ROOT/.build/plugins/urbanvox"
case ":${QGIS_PLUGINPATH:-}:" in
  *":$URBANVOX_ROOT/.build/plugins:"*) ;;
  *) export QGIS_PLUGINPATH="$URBANVOX_ROOT/.build/plugins${QGIS_PLUGINPATH:+:$QGIS_PLUGINPATH}" ;;
esac

if [ -z "${XDG_RUNTIME_DIR:-}" ]; then  # Qt warns on every start without one
  export XDG_RUNTIME_DIR="$URBANVOX_ROOT/.build/runtime"
  mkdir -p -m 700 "$XDG_RUNTIME_DIR"
fi

for _site in "$URBANVOX_ROOT"/.venv/lib/python3*/site-packages; do
  if [ -d "$_site" ]; then
    case ":${PYTHONPATH:-}:" in
      *":$_site:"*) ;;
      *) export PYTHONPATH="$_site${PYTHONPATH:+:$PYTHONPATH}" ;;
    esac
  fi
done
unset _site

export QGIS_PROCESS="${QGIS_PROCESS:-$(command -v qgis_process.bin || command -v qgis_process || true)}"
