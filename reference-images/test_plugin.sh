#!/usr/bin/env bash
# Runs the Mitsuba `btf` plugin tests (needs setup.sh to have been run). Prints "N passed, M failed".
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
exec "$here/.venv/bin/python" "$here/test_plugin.py" "$@"
