#!/usr/bin/env bash
# Self-test of the Slurm scripts on a real Slurm: installs slurm-wlm and munge when missing (as root,
# from Debian's packages), starts a one-node cluster on localhost from a config in a temporary
# folder (its own munge key and socket, slurmctld, slurmd, free ports, run as the current user),
# runs scripts/slurm-render.sh (bands of rows, sample ranges, a task requeued mid-render the way
# preemption does it) and scripts/slurm-fit.sh (3 view ranges, then the assembly) through sbatch on
# a small scene and a small synthetic material, and checks every result byte-identical to a
# one-process run. It stops only the daemons
# it started (by their process ids) and removes the folder (KEEP=1 keeps it for a look).
#
# usage: scripts/slurm-selftest.sh        (env: BTFPT=path/to/btfpt, default target/release/btfpt)
# Run by .ci/run after the tests. Takes about a minute once Slurm is installed.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
bin=${BTFPT:-$root/target/release/btfpt}
log() { echo "slurm-selftest: $*"; }
fail() {
    echo "slurm-selftest: FAILED: $*" >&2
    exit 1
}

if [ ! -x "$bin" ]; then
    log "building $bin"
    (cd "$root" && cargo build --release --quiet)
fi

# --- Slurm and munge from the distribution's packages ------------------------------------------
tools=(slurmctld slurmd sbatch squeue scontrol scancel sinfo munged munge)
missing() { for t in "${tools[@]}"; do command -v "$t" >/dev/null || return 0; done; return 1; }
if missing; then
    [ "$(id -u)" = 0 ] || fail "slurm-wlm and munge are not installed and this is not root: apt-get install slurm-wlm munge"
    log "installing slurm-wlm and munge"
    apt-get update -q >/dev/null
    # The packages' own services stay off (policy-rc.d or no init); this cluster is started below.
    DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends slurm-wlm munge >/dev/null
    if missing; then fail "slurm-wlm/munge installed but ${tools[*]} not all on PATH"; fi
fi
log "$(slurmctld -V), $(munged --version | head -n1)"

# --- A one-node cluster in a temporary folder ------------------------------------------------------
dir=$(mktemp -d "${TMPDIR:-/tmp}/btfpt-slurm.XXXXXX")
chmod 700 "$dir" # munged refuses keys and sockets in folders others can write
daemons=() # pids of the daemons started here, stopped in reverse order
jobs_submitted=()
cleanup() {
    local rc=$?
    set +e
    if [ ${#jobs_submitted[@]} -gt 0 ] && [ -n "${SLURM_CONF:-}" ]; then
        scancel "${jobs_submitted[@]}" 2>/dev/null
        for _ in $(seq 50); do
            [ -z "$(squeue -h -o %i 2>/dev/null)" ] && break
            sleep 0.2
        done
    fi
    for ((k = ${#daemons[@]} - 1; k >= 0; k--)); do
        kill "${daemons[k]}" 2>/dev/null
        for _ in $(seq 50); do
            kill -0 "${daemons[k]}" 2>/dev/null || break
            sleep 0.1
        done
        kill -9 "${daemons[k]}" 2>/dev/null
        wait "${daemons[k]}" 2>/dev/null
    done
    if [ $rc -ne 0 ]; then
        for f in "$dir"/*.log; do
            [ -f "$f" ] && { echo "--- tail of $f" >&2; tail -n 15 "$f" >&2; }
        done
    fi
    if [ "${KEEP:-0}" = 1 ]; then log "kept $dir"; else rm -rf "$dir"; fi
    exit $rc
}
trap cleanup EXIT
trap 'exit 130' INT TERM HUP

free_port() { # a TCP port nothing listens on (bash's /dev/tcp connect fails)
    local p
    for _ in $(seq 100); do
        p=$((20000 + RANDOM % 40000))
        if ! (exec 3<>"/dev/tcp/127.0.0.1/$p") 2>/dev/null; then
            echo "$p"
            return
        fi
    done
    fail "no free port found"
}
until_ok() { # SECONDS WHAT COMMAND...: retries COMMAND every 0.2 s
    local secs=$1 what=$2
    shift 2
    for _ in $(seq $((secs * 5))); do
        if "$@" >/dev/null 2>&1; then return 0; fi
        sleep 0.2
    done
    fail "$what did not come up within $secs s"
}

dd if=/dev/urandom of="$dir/munge.key" bs=1024 count=1 status=none
chmod 600 "$dir/munge.key"
# --force: munged would refuse to run as root and the folder's parents (/tmp) are world-writable.
munged --foreground --force --key-file="$dir/munge.key" --socket="$dir/munge.sock" \
    --pid-file="$dir/munged.pid" --seed-file="$dir/munge.seed" --log-file="$dir/munged.log" \
    >>"$dir/munged.out" 2>&1 &
daemons+=($!)
until_ok 20 munged munge --socket="$dir/munge.sock" --no-input

user=$(id -un)
node=$(hostname -s)
cpus=$(nproc)
ctld_port=$(free_port)
slurmd_port=$(free_port)
[ "$slurmd_port" != "$ctld_port" ] || slurmd_port=$((ctld_port + 1))
mkdir -p "$dir/state" "$dir/spool"
# No cgroups: process tracking by the process tree, no task binding, no accounting database.
cat >"$dir/slurm.conf" <<EOF
ClusterName=btfptselftest
SlurmctldHost=$node(127.0.0.1)
SlurmUser=$user
SlurmdUser=$user
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
AuthType=auth/munge
AuthInfo=socket=$dir/munge.sock
CredType=cred/munge
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
KillWait=10
NodeName=$node NodeAddr=127.0.0.1 CPUs=$cpus State=UNKNOWN
PartitionName=selftest Nodes=ALL Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF=$dir/slurm.conf
slurmctld -D -i -f "$SLURM_CONF" >>"$dir/slurmctld.out" 2>&1 &
daemons+=($!)
until_ok 30 slurmctld scontrol ping
slurmd -D -N "$node" -f "$SLURM_CONF" >>"$dir/slurmd.out" 2>&1 &
daemons+=($!)
node_idle() { [ "$(sinfo -h -N -n "$node" -o %t)" = idle ]; }
until_ok 30 "slurmd (node $node idle)" node_idle
log "cluster up in $dir: $node, $cpus CPUs, slurmctld :$ctld_port, slurmd :$slurmd_port"

# --- Helpers ------------------------------------------------------------------------------------
# Runs a submission script, records and prints the job ids it reports ("... job ID: ...").
submit() {
    local out
    out=$("$@") || fail "submission failed: $*"
    echo "$out"
    local ids
    ids=$(sed -n 's/^.* job \([0-9][0-9]*\):.*$/\1/p' <<<"$out")
    [ -n "$ids" ] || fail "no job ids in the output of $1"
    # shellcheck disable=SC2206 # ids are digits
    jobs_submitted+=($ids)
    echo "$ids" | tail -n1 >"$dir/last-job"
}
state_of() { scontrol show job "$1" 2>/dev/null | sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p' | head -n1; }
wait_job() { # JOBID SECONDS: waits until the job completed, fails on any other end state
    local state
    for _ in $(seq $(($2 * 5))); do
        state=$(state_of "$1")
        case "$state" in
        COMPLETED) return 0 ;;
        FAILED | CANCELLED | TIMEOUT | NODE_FAIL | OUT_OF_MEMORY | BOOT_FAIL | DEADLINE)
            fail "job $1 ended $state" ;;
        esac
        sleep 0.2
    done
    fail "job $1 not finished after $2 s (state ${state:-unknown})"
}
same() { # REFERENCE RESULT WHAT
    cmp -s "$1" "$2" || fail "$3: $2 differs from the one-process $1"
    log "ok: $3 byte-identical to the one-process run ($(stat -c %s "$2") bytes)"
}

# --- Renders --------------------------------------------------------------------------------------
scene=$root/scenes/btf-plane/scene.xml
opts=(-D width=48 -D height=32 -D "btf=synth:corduroy?size=8&seed=1" --seed 3)
"$bin" render "$scene" --spp 64 -o "$dir/ref.exr" "${opts[@]}" 2>/dev/null
submit "$root/scripts/slurm-render.sh" "$scene" --parts 4 --spp 64 -o "$dir/rows.exr" \
    --btfpt "$bin" --sbatch "--cpus-per-task=1" "${opts[@]}"
rows_job=$(cat "$dir/last-job")
submit "$root/scripts/slurm-render.sh" "$scene" --parts 3 --split samples --spp 64 \
    -o "$dir/samples.exr" --btfpt "$bin" "${opts[@]}"
samples_job=$(cat "$dir/last-job")
# Sample ranges merge to the one-process image within a few ulps (f32 means), so the reference is
# the merge of the same three ranges rendered by one process.
for r in 0..21 21..42 42..64; do
    "$bin" render "$scene" --spp-range "$r" -o "$dir/range-${r/../-}.exr" "${opts[@]}" 2>/dev/null
done
"$bin" merge "$dir"/range-*.exr -o "$dir/ref-ranges.exr" 2>/dev/null
wait_job "$rows_job" 120
same "$dir/ref.exr" "$dir/rows.exr" "render split into 4 bands of rows"
wait_job "$samples_job" 120
same "$dir/ref-ranges.exr" "$dir/samples.exr" "render split into 3 sample ranges"

# Preemption: `scontrol requeue` stops a running task (SIGTERM, then SIGKILL after KillWait) and
# queues it again; btfpt checkpoints on SIGTERM and the rerun resumes from the checkpoint.
"$bin" render "$scene" --spp 4096 -o "$dir/ref-long.exr" "${opts[@]}" 2>/dev/null
submit "$root/scripts/slurm-render.sh" "$scene" --parts 2 --spp 4096 -o "$dir/requeued.exr" \
    --btfpt "$bin" --sbatch "--requeue --cpus-per-task=1" "${opts[@]}" --checkpoint-interval 0.2
merge_job=$(cat "$dir/last-job")
array_job=${jobs_submitted[${#jobs_submitted[@]} - 2]}
ckpt=$dir/requeued.exr.farm/part-00000.exr.ckpt
for _ in $(seq 300); do [ -e "$ckpt" ] && break; sleep 0.2; done
[ -e "$ckpt" ] || fail "task 0 wrote no checkpoint within 60 s"
scontrol requeue "${array_job}_0" || fail "scontrol requeue ${array_job}_0 failed"
wait_job "$merge_job" 300
task_log=$(ls "$dir"/requeued.exr.farm/logs/render-"${array_job}"_0.out)
grep -q "interrupted at" "$task_log" || fail "the requeued task did not checkpoint on SIGTERM: $(cat "$task_log")"
grep -q "resuming from" "$task_log" || fail "the requeued task did not resume: $(cat "$task_log")"
same "$dir/ref-long.exr" "$dir/requeued.exr" "render with a task requeued mid-render (resumed from its checkpoint)"

# --- Fit -------------------------------------------------------------------------------------------
"$bin" synth wool --size 8 --strata 1 --format exr -o "$dir/wool8" >/dev/null
fit_opts=(--clusters 8 --features 5)
"$bin" fit "$dir/wool8" -o "$dir/ref.plmc" "${fit_opts[@]}" >/dev/null 2>&1
submit "$root/scripts/slurm-fit.sh" "$dir/wool8" -o "$dir/farm.plmc" --parts 3 --btfpt "$bin" \
    --sbatch "--cpus-per-task=1" "${fit_opts[@]}"
wait_job "$(cat "$dir/last-job")" 300
grep -q "81 views resumed" "$dir"/farm.plmc.farm/logs/fit-join-*.out ||
    fail "the assembly job refitted views: $(cat "$dir"/farm.plmc.farm/logs/fit-join-*.out)"
same "$dir/ref.plmc" "$dir/farm.plmc" "fit split into 3 view ranges, assembled without refitting"

log "all checks passed"
