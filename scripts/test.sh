#!/usr/bin/env bash
# Installs everything (idempotent), then lints and runs the whole test suite on the real stack
# (SAPIEN on lavapipe, Mosquitto, writer and worker processes). Extra arguments go to pytest.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$ROOT/scripts/install.sh"
# the readers the export tests load datagen's exports with (lerobot 0.4.4, mlcroissant, robomimic), in an
# environment of their own (.venv-readers): made once (minutes), then checked; in the background
# while the checks and the pure tests run, which do not use it
READERS_LOG="$(mktemp)"
# its own process group, so that a failed check stops pip too
setsid bash "$ROOT/scripts/readers_env.sh" >"$READERS_LOG" 2>&1 &
READERS_PID=$!
trap 'kill -- "-$READERS_PID" 2>/dev/null || kill "$READERS_PID" 2>/dev/null; rm -f "$READERS_LOG"' EXIT
readers_ready() {
  local rc=0
  wait "$READERS_PID" || rc=$?
  cat "$READERS_LOG"
  rm -f "$READERS_LOG"
  if [ "$rc" -ne 0 ]; then
    echo "[test] the reader environment could not be made (above); the export tests need it" >&2
    exit "$rc"
  fi
}
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
if [ "$#" -gt 0 ]; then
  readers_ready
  echo "[test] pytest $*"
  exec .venv/bin/pytest "$@"
fi
# The whole suite in two runs that split it: first the quick loop exactly as docs/testing.md
# prints it (the pure tests), then every test it leaves out.
echo "[test] pytest: the pure tests (the quick loop of docs/testing.md)"
.venv/bin/pytest -q -n auto -m "not sim and not mqtt and not ray and not slow"
readers_ready
echo "[test] pytest: the tests that use the simulator, the broker, Ray or minutes (two workers)"
# two workers: in one process these tests, which mostly wait on builds, brokers and browsers of
# their own, kept about half of two cores busy (docs/testing.md)
exec .venv/bin/pytest -n 2 -m "sim or mqtt or ray or slow"
