#!/usr/bin/env bash
# The Python package's tests: build it with maturin into a fresh virtual environment (maturin,
# pytest, numpy and miepython from PyPI) and run pytest against the `lucent` binary of the Rust tests.
# Part of the README's test command; run from anywhere.
set -euo pipefail
cd "$(dirname "$0")/.."
start=$(date +%s)
venv="${TMPDIR:-/tmp}/lucent-ci-venv-$$"
trap 'rm -rf "$venv"' EXIT
python3 -m venv "$venv"
# maturin's build hook runs the `maturin` program: put the venv's bin/ first on PATH.
export PATH="$venv/bin:$PATH"
"$venv/bin/python" -m pip install --quiet --upgrade pip
"$venv/bin/python" -m pip install --quiet maturin pytest numpy miepython
"$venv/bin/python" -m pip install --no-build-isolation ./python
# Always build: a binary left from an older checkout would test the package against old code.
cargo build -p lucent
# Run from the repository root so that `import lucent` finds the installed package, not python/lucent.
LUCENT_BIN="$PWD/target/debug/lucent" "$venv/bin/python" -m pytest -q python/tests
echo "python package: built and tested in $(( $(date +%s) - start )) s"
