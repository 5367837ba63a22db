#!/usr/bin/env bash
# Builds the Python module into a venv of its own (target/ci-pyvenv: maturin, numpy, pytest from
# PyPI) and runs pytest over python/tests/ against target/release/btfpt, the CLI the tests compare
# with. pytest's exit code 5 ("no tests collected") fails.
set -euo pipefail
cd "$(dirname "$0")/.."
venv=target/ci-pyvenv
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
"$venv/bin/pip" install --quiet --disable-pip-version-check "maturin==1.16.0" "numpy>=1.21" "pytest>=7"
# Mitsuba for the plugin test only: without it that test is skipped and pytest prints why (-rs).
if ! "$venv/bin/pip" install --quiet --disable-pip-version-check "mitsuba==3.9.1"; then
    echo "python/ci.sh: mitsuba==3.9.1 could not be installed: the Mitsuba plugin test will be skipped" >&2
fi
# The CLI as `cargo test --release` builds it (with the test build's dependency features; a plain
# `cargo build` would compile btfpt again): nothing to do after .ci/run's test step.
cargo test --release --no-run --test architecture
VIRTUAL_ENV="$PWD/$venv" PATH="$PWD/$venv/bin:$PATH" "$venv/bin/maturin" develop --release --quiet
set +e
"$venv/bin/python" -m pytest python/tests -q -rs
rc=$?
set -e
if [ "$rc" -eq 5 ]; then
    echo "python/ci.sh: pytest collected no tests in python/tests/ (exit 5): failing" >&2
    exit 1
fi
exit "$rc"
