#!/bin/bash
# The benchmark on real engines, as docs/bench.md runs it: a small benchmark (12 trials of seed 3, 3 shards)
# through GNU parallel (scripts/bench-parallel), or as a Slurm array job (scripts/bench.sbatch) on a Slurm
# started here on this one machine (munged, slurmctld and slurmd on localhost, in a scratch directory), merged
# with bench-report; the merged lines must equal one unsharded run's, timings aside.
#   tests/app/cluster_bench_test.sh parallel|slurm WELDTWIN_BINARY
# Exit 77 (skipped) where Slurm cannot be started: not root, or its packages missing (scripts/setup installs
# them).
set -euo pipefail
mode=$1 weldtwin=$2
root=$(cd "$(dirname "$0")/../.." && pwd)
work=$(mktemp -d /tmp/weldtwin_cluster_XXXXXX)
export PATH="$(dirname "$weldtwin"):$PATH"
trials=12 seed=3 shards=3
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  sleep 0.5
  for p in "${pids[@]}"; do kill -9 "$p" 2>/dev/null || true; done
  rm -rf "$work"
}
trap cleanup EXIT
fail() { echo "cluster_bench_test ($mode): $*" >&2; exit 1; }

# docs/bench.md shows the scripts this test runs, as they are.
script=$root/scripts/$([ "$mode" = slurm ] && echo bench.sbatch || echo bench-parallel)
python3 - "$script" "$root/docs/bench.md" <<'PY' || fail "docs/bench.md does not show $script as it is"
import sys
sys.exit(0 if open(sys.argv[1]).read() in open(sys.argv[2]).read() else 1)
PY

# The reference: one unsharded run.
weldtwin bench --trials $trials --seed $seed --jobs 2 -q --out "$work/single.jsonl"

if [ "$mode" = parallel ]; then
  command -v parallel >/dev/null || fail "GNU parallel is not installed (scripts/setup installs it)"
  (cd "$work" && "$root/scripts/bench-parallel" $trials $seed $shards 2 merged) || fail "scripts/bench-parallel failed"
  [ "$(tail -n +2 "$work/merged/joblog" | awk '$7 == 0' | wc -l)" -eq $shards ] ||
    fail "the joblog does not show $shards shards that exited 0"
elif [ "$mode" = slurm ]; then
  for b in munged slurmctld slurmd sbatch; do command -v $b >/dev/null || { echo "skipped: no $b"; exit 77; }; done
  [ "$(id -u)" -eq 0 ] || { echo "skipped: starting slurmd needs root"; exit 77; }
  s="$work/slurm"
  mkdir -p "$s/state" "$s/spool" "$s/munge"
  # munge: a key of our own, a socket of our own.
  dd if=/dev/urandom of="$s/munge/munge.key" bs=1024 count=1 status=none
  chmod 400 "$s/munge/munge.key"
  munged --force --key-file="$s/munge/munge.key" --socket="$s/munge/sock" --pid-file="$s/munge/pid" \
    --log-file="$s/munge/log" --seed-file="$s/munge/seed"
  pids+=("$(cat "$s/munge/pid")")
  host=$(hostname -s)
  port=$((20000 + RANDOM % 20000))
  cat >"$s/slurm.conf" <<CONF
ClusterName=weldtwin
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$port
SlurmdPort=$((port + 1))
SlurmUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$s/munge/sock
StateSaveLocation=$s/state
SlurmdSpoolDir=$s/spool
SlurmctldPidFile=$s/slurmctld.pid
SlurmdPidFile=$s/slurmd.pid
SlurmctldLogFile=$s/slurmctld.log
SlurmdLogFile=$s/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/builtin
MpiDefault=none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
ReturnToService=2
NodeName=$host NodeAddr=127.0.0.1 CPUs=$(nproc) State=UNKNOWN
PartitionName=test Nodes=ALL Default=YES MaxTime=INFINITE State=UP
CONF
  export SLURM_CONF="$s/slurm.conf"
  slurmctld -c -f "$SLURM_CONF" || fail "slurmctld did not start: $(tail -5 "$s/slurmctld.log" 2>/dev/null)"
  for _ in $(seq 50); do [ -s "$s/slurmctld.pid" ] && break; sleep 0.1; done
  pids+=("$(cat "$s/slurmctld.pid")")
  slurmd -f "$SLURM_CONF" || fail "slurmd did not start: $(tail -5 "$s/slurmd.log" 2>/dev/null)"
  for _ in $(seq 50); do [ -s "$s/slurmd.pid" ] && break; sleep 0.1; done
  pids+=("$(cat "$s/slurmd.pid")")
  for _ in $(seq 100); do sinfo -h -o %t 2>/dev/null | grep -q idle && break; sleep 0.2; done
  sinfo -h -o %t | grep -q idle || fail "the node did not come up: $(sinfo 2>&1; tail -5 "$s/slurmd.log")"
  # The documented array job, one shard per task, then bench-report after it (afterok).
  cd "$work" && mkdir -p logs
  job=$(sbatch --parsable --array=0-$((shards - 1)) --cpus-per-task=1 \
    --export=ALL,TRIALS=$trials,SEED=$seed,RESULTS=results "$root/scripts/bench.sbatch") || fail "sbatch refused the job"
  timeout 600 sbatch --wait --quiet --dependency=afterok:"$job" --kill-on-invalid-dep=yes \
    --output=logs/report.log --wrap "weldtwin bench-report results/shard-*.jsonl --out merged" ||
    fail "the array job or the merge failed: $(cat logs/*.log 2>/dev/null | tail -20)"
  [ "$(ls results/shard-*.jsonl | wc -l)" -eq $shards ] || fail "not $shards shard files"
else
  fail "unknown mode $mode"
fi

# Merged equals unsharded, every key but the timings.
python3 - "$work/single.jsonl" "$work/merged/results.jsonl" <<'PY' || fail "the merged lines differ from one run's"
import json, sys
def lines(path):
    out = []
    for line in open(path):
        j = json.loads(line)
        j.pop("seconds", None)
        out.append(json.dumps(j, sort_keys=True))
    return out
a, b = lines(sys.argv[1]), lines(sys.argv[2])
if len(a) != 12 or a != b:
    print("single %d lines, merged %d; first difference at %s" % (len(a), len(b),
          next((i for i, (x, y) in enumerate(zip(a, b)) if x != y), min(len(a), len(b)))), file=sys.stderr)
    sys.exit(1)
PY
echo "cluster_bench_test ($mode): $shards shards merged equal one run of $trials trials"
