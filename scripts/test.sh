#!/usr/bin/env bash
# Installs everything (idempotent), then lints and runs the whole test suite on the real stack
# (SAPIEN on lavapipe, Mosquitto, writer and worker processes). Extra arguments go to pytest.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$ROOT/scripts/install.sh"
cd "$ROOT"
echo "[test] ruff format --check, ruff check, lint-imports (import contracts in pyproject.toml)"
.venv/bin/ruff format --check --quiet .
.venv/bin/ruff check --quiet .
.venv/bin/lint-imports --no-cache >/dev/null || .venv/bin/lint-imports --no-cache
echo "[test] pytest"
exec .venv/bin/pytest "$@"
