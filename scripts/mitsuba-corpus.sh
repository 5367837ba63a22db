#!/usr/bin/env bash
# Tries every Mitsuba XML scene under the given folders with btfpt: loads it and renders one
# pixel at 1 spp (so meshes, textures and emitters are all built). Prints one line per scene:
#   OK <file>            loads unchanged
#   FAIL <file> <error>  the first line of btfpt's error
# and a summary. Usage: scripts/mitsuba-corpus.sh [--btfpt PATH] FOLDER...
# (docs/mitsuba-scenes.md lists the collections tried and the results.)
set -u
btfpt=target/release/btfpt
if [ "${1:-}" = "--btfpt" ]; then btfpt=$2; shift 2; fi
out=$(mktemp -d)
ok=0; fail=0
while IFS= read -r f; do
    if err=$(timeout 300 "$btfpt" render "$f" --crop 0,0,1,1 --spp 1 --threads 1 -o "$out/x.exr" 2>&1 >/dev/null); then
        echo "OK $f"; ok=$((ok + 1))
    else
        msg=$(printf '%s\n' "$err" | grep -v '^\s*$' | grep -iv '^scene \|^  ' | head -1)
        echo "FAIL $f $msg"; fail=$((fail + 1))
    fi
done < <(find "$@" -name '*.xml' | sort)
echo "loaded $ok, failed $fail"
rm -rf "$out"
