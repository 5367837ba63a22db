# shellcheck shell=bash disable=SC2154,SC2034 # prog is set by the sourcing script, array/join are read by it
# Shared by scripts/slurm-render.sh and scripts/slurm-fit.sh (sourced, not run): argument checks,
# path and quoting helpers for the generated job scripts, and the array + dependent-job submission.
# The sourcing script sets `prog` (its name, for messages) before sourcing.

die() {
    echo "$prog: $*" >&2
    exit 2
}

# The btfpt binary: $1 if given, else $BTFPT, else `btfpt` on PATH, else this checkout's release build.
find_btfpt() {
    local bin=${1:-${BTFPT:-}}
    if [ -z "$bin" ]; then
        bin=$(command -v btfpt || true)
        [ -n "$bin" ] || bin="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)/target/release/btfpt"
    fi
    [ -x "$bin" ] || die "$bin: btfpt binary not found or not executable (use --btfpt BIN)"
    abs "$bin"
}

# Absolute path without resolving symlinks (the compute nodes see the same paths).
abs() {
    case "$1" in /*) printf '%s\n' "$1" ;; *) printf '%s/%s\n' "$PWD" "$1" ;; esac
}

q() { [ $# -eq 0 ] || printf '%q ' "$@"; } # shell-quoted words, each followed by a space
qw() { printf '%q' "$1"; }                  # one shell-quoted word

check_parts_count() { [[ "$1" =~ ^[1-9][0-9]*$ ]] || die "--parts '$1': expected a positive integer"; }

check_sbatch() { command -v sbatch >/dev/null || die "sbatch not found: run this on a Slurm login node"; }

# submit_array_and_join NAME PARTS WORK TASK_SCRIPT JOIN_SCRIPT SBATCH_EXTRA: submits TASK_SCRIPT
# as an array of PARTS tasks (logs appended per task, so a requeued task's runs share one log) and
# JOIN_SCRIPT once every task succeeded (cancelled if one failed). Sets `array` and `join`.
submit_array_and_join() {
    local name=$1 parts=$2 work=$3 task=$4 joiner=$5 extra
    read -ra extra <<<"$6"
    jobid() { # sbatch --parsable prints ID or ID;CLUSTER
        local id=${1%%;*}
        [[ "$id" =~ ^[0-9]+$ ]] || die "unexpected sbatch output '$1'"
        printf '%s\n' "$id"
    }
    array=$(jobid "$(sbatch --parsable --job-name="btfpt-$name" --array="0-$((parts - 1))" \
        --chdir="$work" --open-mode=append --output="$work/logs/$name-%A_%a.out" \
        ${extra[@]+"${extra[@]}"} "$task")")
    join=$(jobid "$(sbatch --parsable --job-name="btfpt-$name-join" --dependency="afterok:$array" \
        --kill-on-invalid-dep=yes --chdir="$work" --output="$work/logs/$name-join-%j.out" \
        ${extra[@]+"${extra[@]}"} "$joiner")")
}
