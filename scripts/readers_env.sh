#!/usr/bin/env bash
# Creates, once, the separate environment in which the tests read datagen's exports back with the
# readers users load them with: lerobot 0.4.4 (the newest release for Python 3.11; it reads the
# LeRobot v3.0 format and pins torch < 2.11, older than datagen's) with its arms' motor SDKs,
# mlcroissant (it needs numpy 2; datagen pins numpy 1.26) and robomimic 0.3.0. datagen itself
# never imports any of them. The stamp lists what is installed and a second run does nothing; an
# environment made before the later packages were added gets them added in place (the
# environment is made afresh only when its first step's packages change). First run: about 3 min
# and 8 GB (lerobot's torch is a CUDA build).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
ENV="${DATAGEN_READERS_ENV:-$ROOT/.venv-readers}"
WANT="lerobot==0.4.4 mlcroissant==1.1.1"
# robomimic 0.3.0 declares egl_probe (built from source with cmake), tensorboard and an unpinned
# torch: it goes in without its dependencies (lerobot's torch and torchvision serve it), with
# what its utils (env_utils, file_utils, obs_utils) and SequenceDataset import beside those
ROBOMIMIC="robomimic==0.3.0"
ROBOMIMIC_NEEDS="h5py==3.16.0 matplotlib==3.11.2"
# the motor buses of lerobot's so100_follower (Feetech) and koch_follower (Dynamixel), which
# their robot classes import when built (lerobot[feetech], lerobot[dynamixel]; no port is opened)
MOTOR_SDKS="feetech-servo-sdk==1.0.0 dynamixel-sdk==3.8.4"
STAMP="$ENV/.datagen-readers-stamp"
ALL="$WANT $ROBOMIMIC $ROBOMIMIC_NEEDS $MOTOR_SDKS"
say() { printf '\033[1m[readers]\033[0m %s\n' "$*"; }
have="$(cat "$STAMP" 2>/dev/null || true)"
if [ "$have" = "$ALL" ]; then
    say "reader environment up to date ($ENV)"
    exit 0
fi
pip_install() {  # pip_install ARGS...: quiet, its output shown only when it fails
    local log
    log="$(mktemp)"
    if ! "$ENV/bin/python" -m pip install -q "$@" >"$log" 2>&1; then
        grep -v "is ignored: it is neither a file nor a directory" "$log" >&2 || true
        rm -f "$log"
        echo "[readers] error: pip install $* failed (pip's output above)" >&2
        exit 1
    fi
    rm -f "$log"
}
if [ "${have#"$WANT"}" = "$have" ]; then  # the stamp does not begin with the first step's
    PYTHON="${DATAGEN_PYTHON:-$(command -v python3.11 || command -v python3)}"
    say "creating $ENV with $WANT (first time: a few minutes)"
    rm -rf "$ENV"
    "$PYTHON" -m venv "$ENV"
    # shellcheck disable=SC2086  # the list splits into its packages
    pip_install $WANT
    "$ENV/bin/python" -c "import lerobot.datasets.lerobot_dataset, mlcroissant"
    echo "$WANT" > "$STAMP"
fi
say "adding $ROBOMIMIC and $MOTOR_SDKS to $ENV"
pip_install --no-deps "$ROBOMIMIC"
# shellcheck disable=SC2086
pip_install $ROBOMIMIC_NEEDS $MOTOR_SDKS
"$ENV/bin/python" -c "import robomimic.utils.file_utils, robomimic.utils.env_utils, robomimic.utils.dataset" >/dev/null  # it prints a warning on import
"$ENV/bin/python" -c "import scservo_sdk, dynamixel_sdk"
echo "$ALL" > "$STAMP"
say "done: $ENV"
