#!/usr/bin/env bash
# Idempotent setup of the Mitsuba 3 reference pipeline.
# Creates reference-images/.venv (git-ignored) with pinned packages and makes sure the LLVM
# shared library needed by Dr.Jit's LLVM backend (`llvm_ad_rgb`) is present.
# On Debian 12: LLVM 14 is rejected by Dr.Jit, 15/16 crash, 19 works -> install libllvm19.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
venv="$here/.venv"
python="${PYTHON:-python3}"

# 1. libLLVM 19 (only if no usable libLLVM >= 17 is already found).
have_llvm() {
    local f
    for f in /usr/lib/x86_64-linux-gnu/libLLVM-19*.so* /usr/lib/x86_64-linux-gnu/libLLVM.so.19*; do
        [ -e "$f" ] && return 0
    done
    return 1
}
if ! have_llvm; then
    if command -v apt-get >/dev/null 2>&1; then
        sudo_cmd=""
        if [ "$(id -u)" != 0 ]; then sudo_cmd="sudo"; fi
        echo "setup.sh: installing libllvm19 (needed by llvm_ad_rgb)" >&2
        $sudo_cmd apt-get update -qq || true
        DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq libllvm19
    else
        echo "setup.sh: libLLVM 19 not found and apt-get unavailable; install LLVM >= 17 and set DRJIT_LIBLLVM_PATH" >&2
        exit 1
    fi
fi

# 2. The venv with pinned packages.
if [ ! -x "$venv/bin/python" ]; then
    "$python" -m venv "$venv"
fi
req="$here/requirements.txt"
stamp="$venv/.requirements.sha256"
want="$(sha256sum "$req" | cut -d' ' -f1)"
if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$want" ]; then
    "$venv/bin/python" -m pip install -q --disable-pip-version-check -r "$req"
    echo "$want" > "$stamp"
fi

# 3. Smoke test: the LLVM variant must load.
"$venv/bin/python" - <<'PY'
import mitsuba as mi
mi.set_variant("llvm_ad_rgb")
print("setup.sh: mitsuba", mi.__version__, "variant", mi.variant(), "OK")
PY
