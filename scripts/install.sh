#!/usr/bin/env bash
# Installs everything datagen needs on Debian 12 (bookworm), idempotently:
#   system: Mosquitto (+ clients; on bookworm 2.0.21 from bookworm-backports, built with
#           WebSockets for the live monitor), Chromium (the monitor's browser test), the
#           Vulkan loader, and Mesa lavapipe from bookworm-backports when no Vulkan device
#           can render;
#   python: a virtual environment in .venv with datagen and its dependencies;
#   the picture library (datagen library install) in ~/.cache/datagen/library.
# A second run checks each step and skips what is already done.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="${DATAGEN_VENV:-$ROOT/.venv}"
STAMP="$VENV/.datagen-install-stamp"

say() { printf '\033[1m[install]\033[0m %s\n' "$*"; }
die() { printf '\033[31m[install] error:\033[0m %s\n' "$*" >&2; exit 1; }

# --- the system must be one we know how to set up ---------------------------------------------
[ "$(uname -s)" = "Linux" ] || die "unsupported system $(uname -s): datagen's installer supports Debian 12 (bookworm) on Linux."
command -v apt-get >/dev/null || die "apt-get not found: this installer supports Debian 12 (bookworm). On other systems install Mosquitto, a Vulkan driver (Mesa >= 24.3 lavapipe without a GPU) and Python 3.11, then 'pip install -e .[dev]'."
. /etc/os-release
CODENAME="${VERSION_CODENAME:-unknown}"
if [ "${ID:-}" != "debian" ] || [ "$CODENAME" != "bookworm" ]; then
    say "warning: tested on Debian 12 (bookworm); this is ${PRETTY_NAME:-unknown}. Continuing."
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
    command -v sudo >/dev/null || die "not root and sudo is missing: run as root or install sudo."
    SUDO="sudo"
fi

PYTHON="${DATAGEN_PYTHON:-}"
if [ -z "$PYTHON" ]; then
    for candidate in python3.11 python3; do
        if command -v "$candidate" >/dev/null && "$candidate" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))'; then
            PYTHON="$(command -v "$candidate")"; break
        fi
    done
fi
[ -n "$PYTHON" ] || die "Python 3.11 not found (datagen's pinned simulator wheels are built for 3.11). Install python3.11 or set DATAGEN_PYTHON."

APT_UPDATED=0
apt_update_once() {
    if [ "$APT_UPDATED" -eq 0 ]; then
        say "apt-get update"
        $SUDO apt-get update -qq
        APT_UPDATED=1
    fi
}
apt_install() {  # installs only the packages that are missing
    local missing=()
    for pkg in "$@"; do
        dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || missing+=("$pkg")
    done
    if [ ${#missing[@]} -gt 0 ]; then
        apt_update_once
        say "apt-get install ${missing[*]}"
        DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
    fi
}

ensure_backports() {
    if ! grep -rqs "bookworm-backports" /etc/apt/sources.list /etc/apt/sources.list.d/; then
        echo "deb http://deb.debian.org/debian bookworm-backports main" | $SUDO tee /etc/apt/sources.list.d/bookworm-backports.list >/dev/null
        APT_UPDATED=0
    fi
}

# --- system packages ----------------------------------------------------------------------------
if [ "$CODENAME" = "bookworm" ]; then
    # Debian 12's own mosquitto 2.0.11 is built without WebSockets, which the live monitor's
    # page needs (docs/monitor.md); bookworm-backports carries 2.0.21 built with libwebsockets
    if ! dpkg-query -W -f='${Status} ${Version}' mosquitto 2>/dev/null | grep -q "install ok installed .*bpo"; then
        ensure_backports
        apt_update_once
        say "apt-get install -t bookworm-backports mosquitto mosquitto-clients (with WebSockets)"
        DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends -t bookworm-backports mosquitto mosquitto-clients >/dev/null
    fi
else
    say "warning: not bookworm: install a Mosquitto built with WebSockets for 'datagen monitor'"
fi
say "system packages: mosquitto, mosquitto-clients, Vulkan loader, libusb (Open3D loads it), libgomp, chromium"
apt_install mosquitto mosquitto-clients libvulkan1 ca-certificates procps libusb-1.0-0 libgomp1 chromium
if ! "$PYTHON" -m venv --help >/dev/null 2>&1; then apt_install python3-venv; fi

pip_install() {  # quiet on success; on failure shows pip's output and stops
    local log
    log="$(mktemp)"
    if ! "$VENV/bin/python" -m pip install -q "$@" >"$log" 2>&1; then
        grep -v "is ignored: it is neither a file nor a directory" "$log" >&2 || true
        rm -f "$log"
        die "pip install $* failed (pip's output above)"
    fi
    rm -f "$log"
}

# --- python environment -------------------------------------------------------------------------
WANT="$(cat "$ROOT/pyproject.toml" "$ROOT/scripts/install.sh" | sha256sum | cut -d' ' -f1)"
if [ ! -x "$VENV/bin/python" ]; then
    say "creating virtual environment $VENV"
    "$PYTHON" -m venv "$VENV"
fi
if [ "$(cat "$STAMP" 2>/dev/null)" != "$WANT" ]; then
    say "installing datagen and its dependencies into $VENV (first time: a few minutes)"
    pip_install --upgrade pip
    # torch first: the project machines carry the CPU build of 2.13.0 in pip's find-links;
    # resolving it through mani-skill instead would pull several GB of CUDA wheels
    pip_install "torch==2.13.0"
    pip_install -e "$ROOT[dev]"
    # sapien requires opencv-python (GUI build, needs libGL); we use opencv-python-headless.
    # Both unpack into site-packages/cv2: reinstalling headless last makes its files the ones on disk.
    pip_install --force-reinstall --no-deps "opencv-python-headless==4.10.0.84"
    echo "$WANT" > "$STAMP"
else
    say "python environment up to date ($VENV)"
fi
"$VENV/bin/python" -c "import cv2, numpy, open3d, h5py, pycocotools.mask; assert numpy.__version__.startswith('1.')" \
    || die "importing cv2, open3d, h5py or pycocotools fails in $VENV: remove $STAMP and run this script again."

# --- rendering: a Vulkan device, or Mesa lavapipe from bookworm-backports ------------------------
probe_render() { "$VENV/bin/python" -m datagen.sensing.render_probe >/dev/null 2>&1; }
if probe_render; then
    say "rendering: $("$VENV/bin/python" -m datagen.sensing.render_probe 2>/dev/null)"
else
    [ "$CODENAME" = "bookworm" ] || die "no Vulkan device can render and this is not Debian bookworm: install Mesa >= 24.3 (mesa-vulkan-drivers) or a GPU driver with Vulkan."
    say "no Vulkan device renders: installing Mesa lavapipe from bookworm-backports (Debian 12's Mesa 22.3 lacks VK_KHR_external_semaphore_fd)"
    ensure_backports
    apt_update_once
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends -t bookworm-backports mesa-vulkan-drivers >/dev/null
    probe_render || die "SAPIEN still cannot render after installing Mesa from bookworm-backports; run '$VENV/bin/python -m datagen.sensing.render_probe' to see why."
    say "rendering: $("$VENV/bin/python" -m datagen.sensing.render_probe 2>/dev/null)"
fi
# --- the picture library: photographs, material pictures, meshes (docs/photo-library.md) ---------
# fetched from Debian's and PyPI's registries into $DATAGEN_LIBRARY (~/.cache/datagen/library)
if ! "$VENV/bin/datagen" library install; then
    apt_update_once  # apt-get download needs the package lists
    "$VENV/bin/datagen" library install || die "the picture library could not be installed (see above)"
fi

say "done: activate with 'source $VENV/bin/activate' or call $VENV/bin/datagen"
