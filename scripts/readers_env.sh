#!/usr/bin/env bash
# Creates, once, the separate environment in which the tests read datagen's exports back with the
# readers users load them with: lerobot 0.4.4 (the newest release for Python 3.11; it reads the
# LeRobot v3.0 format and pins torch < 2.11, older than datagen's) and mlcroissant (it needs
# numpy 2; datagen pins numpy 1.26). datagen itself never imports either. A second run checks a
# stamp and does nothing. First run: about 2.5 min and 8 GB (lerobot's torch is a CUDA build).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
ENV="${DATAGEN_READERS_ENV:-$ROOT/.venv-readers}"
WANT="lerobot==0.4.4 mlcroissant==1.1.1"
STAMP="$ENV/.datagen-readers-stamp"
say() { printf '\033[1m[readers]\033[0m %s\n' "$*"; }
if [ "$(cat "$STAMP" 2>/dev/null)" = "$WANT" ]; then
    say "reader environment up to date ($ENV)"
    exit 0
fi
PYTHON="${DATAGEN_PYTHON:-$(command -v python3.11 || command -v python3)}"
say "creating $ENV with $WANT (first time: a few minutes)"
rm -rf "$ENV"
"$PYTHON" -m venv "$ENV"
log="$(mktemp)"
if ! "$ENV/bin/python" -m pip install -q $WANT >"$log" 2>&1; then
    grep -v "is ignored: it is neither a file nor a directory" "$log" >&2 || true
    rm -f "$log"
    echo "[readers] error: pip install $WANT failed (pip's output above)" >&2
    exit 1
fi
rm -f "$log"
"$ENV/bin/python" -c "import lerobot.datasets.lerobot_dataset, mlcroissant"
echo "$WANT" > "$STAMP"
say "done: $ENV"
