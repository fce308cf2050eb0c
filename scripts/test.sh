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
echo "[test] mypy (typed boundaries)"
.venv/bin/mypy
echo "[test] mkdocs build --strict (the documentation site, built outside the tree)"
SITE="$(mktemp -d)"
.venv/bin/mkdocs build --strict --quiet -d "$SITE"
rm -rf "$SITE"
echo "[test] pytest"
exec .venv/bin/pytest "$@"
