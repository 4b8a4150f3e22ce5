#!/usr/bin/env bash
# Start a throw-away single-node Slurm on this machine, build manifests as a job array with
# deploy/slurm/array.sbatch, and check the result against an unsharded build:
#
#   - every array task ends COMPLETED with exit code 0;
#   - every table is assembled by the array itself (no rerun, no finalize job), verifies, and
#     no work directory is left;
#   - the catalog is current (rebuilding it changes nothing) and equals the unsharded build's;
#   - every table is byte-identical to the unsharded build (SOURCE_DATE_EPOCH fixed).
#
# Usage (as root, from anywhere; Debian 12 packages: slurmctld slurmd slurm-client munge):
#
#   deploy/slurm/single-node-test.sh [MANIFEST...]     # default: debye + hair-dual manifests
#
# Environment:
#   SCATTERBAKE_BIN   the scatterbake binary (default: `scatterbake` on PATH, else
#                     target/release/scatterbake of this checkout)
#   SHARDS            array size N, submitted as --array=0-(N-1) (default 4)
#   NODE_CPUS         CPUs of the Slurm node (default: nproc); each array task gets 1 CPU
#   SLURM_TEST_PORT   slurmctld port; slurmd uses the next one (default 16817)
#   SLURM_TEST_TIMEOUT seconds to wait for the array (default 900)
#   KEEP=1            keep the temporary directory (configuration, logs, tables)
#   REFERENCE=0       no unsharded build (for manifests too costly to build twice): the tables
#                     expected are the plan's (`build --plan --json`), and the two comparisons
#                     with the unsharded build (bytes, catalog) are left out
#
# Everything (munge key and socket, slurm.conf, state, spool, logs, tables) lives in one
# temporary directory; the system's /etc/slurm and munge daemon are not used. The daemons started
# here are stopped on exit, by process id. The last lines are a summary; the exit code is 0 only
# when every check passed.
set -euo pipefail

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
cd "$repo"
if [ "$#" -gt 0 ]; then
    manifests=("$@")
else
    manifests=(manifests/debye.toml manifests/hair-dual.toml)
fi
shards=${SHARDS:-4}
cpus=${NODE_CPUS:-$(nproc)}
port=${SLURM_TEST_PORT:-16817}
timeout=${SLURM_TEST_TIMEOUT:-900}
export SOURCE_DATE_EPOCH=${SOURCE_DATE_EPOCH:-1700000000}

say() { echo "slurm-test: $*"; }
# Seconds since a `date +%s.%N` stamp, one decimal.
since() { awk -v a="$1" -v b="$(date +%s.%N)" 'BEGIN { printf "%.1f", b - a }'; }
fail() {
    say "FAIL: $*"
    exit 1
}

# --- Prerequisites: a missing one is a failure, never a skip. ---
missing=()
for c in sbatch squeue scontrol sinfo scancel slurmctld slurmd munged munge; do
    command -v "$c" >/dev/null || missing+=("$c")
done
if [ "${#missing[@]}" -gt 0 ]; then
    fail "missing ${missing[*]} (install: apt-get install -y slurmctld slurmd slurm-client munge)"
fi
[ "$(id -u)" -eq 0 ] || fail "must run as root (slurmd starts jobs as the submitting user)"
bin=${SCATTERBAKE_BIN:-$(command -v scatterbake || echo "$repo/target/release/scatterbake")}
[ -x "$bin" ] || fail "no scatterbake binary at $bin (set SCATTERBAKE_BIN)"
bin=$(cd "$(dirname "$bin")" && pwd)/$(basename "$bin")

# --- One temporary directory for everything. ---
tmp=$(mktemp -d /tmp/scatterbake-slurm.XXXXXX)
chmod 755 "$tmp"
mkdir -p "$tmp"/{etc,munge,state,spool,log,run,jobs}
chmod 755 "$tmp/munge"
pids=()
cleanup() {
    local rc=$?
    if [ -n "${job:-}" ]; then scancel "$job" 2>/dev/null || true; fi
    # Stop the daemons started here, by process id, and wait for them.
    for ((i = ${#pids[@]} - 1; i >= 0; i--)); do
        kill "${pids[i]}" 2>/dev/null || true
    done
    for p in "${pids[@]}"; do
        wait "$p" 2>/dev/null || true
    done
    if [ "$rc" -ne 0 ]; then
        for f in "$tmp"/log/*.log "$tmp"/jobs/*.log; do
            [ -f "$f" ] || continue
            echo "----- tail of $f"
            tail -n 20 "$f"
        done
    fi
    if [ "${KEEP:-0}" = 1 ]; then
        say "kept $tmp"
    else
        rm -rf "$tmp"
    fi
    exit "$rc"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

# --- munge: a fresh key and a private socket. ---
dd if=/dev/urandom of="$tmp/munge/munge.key" bs=1024 count=1 status=none
chmod 400 "$tmp/munge/munge.key"
socket=$tmp/munge/munge.socket
munged --foreground --force --socket="$socket" --key-file="$tmp/munge/munge.key" \
    --pid-file="$tmp/munge/munged.pid" --log-file="$tmp/log/munged.log" \
    --seed-file="$tmp/munge/munged.seed" >"$tmp/log/munged.out" 2>&1 &
pids+=($!)
for _ in $(seq 50); do
    [ -S "$socket" ] && break
    sleep 0.1
done
munge -n -S "$socket" | unmunge -S "$socket" >/dev/null || fail "munge does not work"

# --- slurm.conf for this host: one node, one partition, no cgroups, no accounting. ---
host=$(hostname -s)
conf=$tmp/etc/slurm.conf
cat >"$conf" <<EOF
ClusterName=scatterbake-test
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$port
SlurmdPort=$((port + 1))
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$socket
StateSaveLocation=$tmp/state
SlurmdSpoolDir=$tmp/spool
SlurmctldPidFile=$tmp/run/slurmctld.pid
SlurmdPidFile=$tmp/run/slurmd.pid
SlurmctldLogFile=$tmp/log/slurmctld.log
SlurmdLogFile=$tmp/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/backfill
MpiDefault=none
ReturnToService=2
MinJobAge=3600
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus State=UNKNOWN
PartitionName=test Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF=$conf
slurmctld -D -i -f "$conf" >"$tmp/log/slurmctld.out" 2>&1 &
pids+=($!)
slurmd -D -f "$conf" -N "$host" >"$tmp/log/slurmd.out" 2>&1 &
pids+=($!)
state=
for _ in $(seq 120); do
    state=$(sinfo -h -N -o %T 2>/dev/null | head -n 1 || true)
    [ "$state" = idle ] && break
    sleep 0.5
done
[ "$state" = idle ] || fail "node not idle after 60 s (state: '${state:-none}')"
say "single-node Slurm up: $(sinfo --version), node $host, $cpus CPUs"

# --- Reference: one unsharded build of the same manifests (or, with REFERENCE=0, the plan). ---
ref=$tmp/ref
reference=${REFERENCE:-1}
if [ "$reference" = 0 ]; then
    "$bin" build "${manifests[@]}" --plan --json >"$tmp/log/plan.json" ||
        fail "build --plan failed"
    mapfile -t tables < <(python3 -c 'import json, sys
for t in json.load(open(sys.argv[1]))["tables"]:
    print(t["name"] + ".sbt")' "$tmp/log/plan.json")
    ref_s=skipped
else
    t0=$(date +%s.%N)
    env -u SLURM_ARRAY_TASK_ID -u SLURM_ARRAY_TASK_COUNT -u JOB_COMPLETION_INDEX \
        "$bin" build "${manifests[@]}" --out "$ref" --quiet --no-previews >"$tmp/log/ref.out" 2>&1 ||
        fail "unsharded build failed: $(cat "$tmp/log/ref.out")"
    ref_s="$(since "$t0") s"
    mapfile -t tables < <(cd "$ref" && ls -- *.sbt)
fi
[ "${#tables[@]}" -gt 0 ] || fail "no table expected (the unsharded build wrote none)"

# --- The array. ---
shared=$tmp/shared
t0=$(date +%s.%N)
job=$(SCATTERBAKE_BIN=$bin sbatch --parsable --array=0-$((shards - 1)) --cpus-per-task=1 \
    --chdir="$repo" --output="$tmp/jobs/%A_%a.log" \
    deploy/slurm/array.sbatch "${manifests[@]}" "$shared")
job=${job%%;*}
say "submitted array job $job: --array=0-$((shards - 1)) over ${manifests[*]}"
deadline=$(($(date +%s) + timeout))
while [ -n "$(squeue -h -j "$job" 2>/dev/null)" ]; do
    [ "$(date +%s)" -lt "$deadline" ] || fail "array job $job not done after $timeout s"
    sleep 0.5
done
wall_s=$(since "$t0")

# --- Checks. ---
errors=0
check() {
    if eval "$2"; then say "ok: $1"; else
        say "FAILED: $1"
        errors=$((errors + 1))
    fi
}
states=$(scontrol show job "$job" -o | grep -o 'JobState=[A-Z_]* .*ExitCode=[0-9:]*' |
    sed 's/JobState=\([A-Z_]*\).*ExitCode=\([0-9:]*\)/\1 \2/' | sort | uniq -c | xargs)
completed=$(scontrol show job "$job" -o | grep -c 'JobState=COMPLETED .*ExitCode=0:0' || true)
check "$completed of $shards array tasks COMPLETED with exit code 0 ($states)" \
    '[ "$completed" -eq "$shards" ]'
for ((i = 0; i < shards; i++)); do
    say "  shard $i/$shards: $(tail -n 1 "$tmp/jobs/${job}_$i.log" 2>/dev/null || echo 'no log')"
done
built=$(cat "$tmp"/jobs/*.log | grep -o '^built [0-9]*' | awk '{s += $2} END {print s + 0}')
present=0
identical=0
for t in "${tables[@]}"; do
    [ -f "$shared/$t" ] && present=$((present + 1))
    cmp -s "$ref/$t" "$shared/$t" && identical=$((identical + 1))
done
# Nothing ran between the array and this check: every table present was assembled by a shard.
check "${#tables[@]} tables expected, $present present after the array ($built table writes reported by the shards)" \
    '[ "$present" -eq "${#tables[@]}" ] && [ "$built" -ge "${#tables[@]}" ]'
check "no work directory left" '[ ! -e "$shared/.work" ]'
check "every table verifies" '"$bin" verify "$shared"/*.sbt >"$tmp/log/verify.out" 2>&1'
if [ "$reference" != 0 ]; then
    check "byte comparison: $identical of ${#tables[@]} tables identical to the unsharded build" \
        '[ "$identical" -eq "${#tables[@]}" ]'
fi
cp "$shared/index.json" "$tmp/index.before.json"
"$bin" catalog "$shared" >/dev/null
check "catalog current: rebuilding it changes nothing" \
    'cmp -s "$tmp/index.before.json" "$shared/index.json"'
if [ "$reference" != 0 ]; then
    check "catalog identical to the unsharded build's" 'cmp -s "$ref/index.json" "$shared/index.json"'
fi
say "summary: shards $shards, node CPUs $cpus, wall time ${wall_s} s (submit to last shard done), unsharded build ${ref_s}, tables ${present}/${#tables[@]} assembled by the array, $([ "$reference" = 0 ] && echo "no byte comparison" || echo "${identical}/${#tables[@]} byte-identical")"
[ "$errors" -eq 0 ] || fail "$errors check(s) failed"
say "PASS"
