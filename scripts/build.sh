#!/usr/bin/env bash
# Installs everything (idempotent), then builds the default dataset:
# 100 randomised grasping scenes at 640x480 into datasets/grasp_tabletop/.
# Extra arguments go to `datagen build`, e.g. --num-samples 1000 --workers 4.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$ROOT/scripts/install.sh"
cd "$ROOT"
exec .venv/bin/datagen build configs/grasp_tabletop.yaml --out datasets/grasp_tabletop "$@"
