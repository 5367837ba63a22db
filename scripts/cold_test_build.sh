#!/usr/bin/env bash
# CPU time of a cold test build at each given revision: in a detached worktree with an empty
# target dir, `cargo build --release` (dependencies and the crate) and then
# `cargo test --release --no-run` (the test binaries), each timed by GNU time (user + sys CPU
# seconds, which a loaded machine changes far less than wall time), plus the number of test
# executables. Runs at nice 19; delete the printed folders when done.
# usage: scripts/cold_test_build.sh REV [REV ...]   e.g. 88fccfd^ 88fccfd (25 vs 7 test binaries)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
[ -x /usr/bin/time ] || { echo "$0: needs /usr/bin/time (GNU time)" >&2; exit 2; }
for rev in "$@"; do
    dir=$(mktemp -d)
    git -C "$root" worktree add --detach "$dir/src" "$rev" >/dev/null
    export CARGO_TARGET_DIR="$dir/target"
    (cd "$dir/src" && /usr/bin/time -f "$rev build: user %U s, sys %S s, wall %e s" \
        nice -n 19 cargo build --release --locked --quiet)
    (cd "$dir/src" && /usr/bin/time -o "$dir/time.txt" \
        -f "$rev test --no-run: user %U s, sys %S s, wall %e s" \
        nice -n 19 cargo test --release --locked --no-run 2> "$dir/test.log")
    cat "$dir/time.txt"
    echo "$rev: $(grep -c Executable "$dir/test.log") test executables; worktree and target in $dir"
    git -C "$root" worktree remove --force "$dir/src"
done
