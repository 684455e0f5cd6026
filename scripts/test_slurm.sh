#!/usr/bin/env bash
# The README's Slurm job array, for real, on this machine: installs Slurm and munge from
# Debian's packages (needs root and apt), starts a single-node cluster on the loopback
# interface only (munged, slurmctld, slurmd, each with its files in a temporary folder, ports
# 16817/16818), submits the README's `tumble dataset` array as 4 shards and the merge as a job
# depending on it, waits, checks that the merged dataset is byte for byte the unsharded one,
# and stops every daemon it started by its PID (also on failure).
# Usage: sudo bash scripts/test_slurm.sh [SPEC]   (default models/dataset.toml)
# Not part of .ci/run: it needs root, apt and free ports 16817-16818.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
repo=$(pwd)
spec=$(realpath "${1:-models/dataset.toml}")
if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq slurm-wlm munge >/dev/null
fi
cargo build --release --quiet
tumble="$repo/target/release/tumble"
work=$(mktemp -d /tmp/tumble-slurm.XXXXXX)
chmod 755 "$work"
pids=()
stop() {
  for pidfile in "$work/slurmd.pid" "$work/slurmctld.pid" "$work/munged.pid"; do
    [ -s "$pidfile" ] || continue
    pid=$(cat "$pidfile")
    if kill "$pid" 2>/dev/null; then
      for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
      echo "stopped $(basename "$pidfile" .pid) (pid $pid)"
    fi
  done
}
trap stop EXIT
host=$(hostname -s)
cpus=$(nproc)
echo "== munge (socket $work/munge.socket)"
mungekey --create --keyfile="$work/munge.key" --force
chmod 600 "$work/munge.key"
munged --force --socket="$work/munge.socket" --key-file="$work/munge.key" \
  --pid-file="$work/munged.pid" --log-file="$work/munged.log" --seed-file="$work/munge.seed"
for _ in $(seq 50); do [ -s "$work/munged.pid" ] && break; sleep 0.1; done
echo "munged pid $(cat "$work/munged.pid")"
echo "== slurm.conf"
mkdir -p "$work/spool" "$work/state"
cat >"$work/slurm.conf" <<CONF
ClusterName=tumble-test
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=16817
SlurmdPort=16818
SlurmUser=root
AuthType=auth/munge
AuthInfo=socket=$work/munge.socket
CredType=cred/munge
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/slurmctld.log
SlurmdLogFile=$work/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/none
MpiDefault=none
ReturnToService=2
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus State=UNKNOWN
PartitionName=local Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF="$work/slurm.conf"
echo "== slurmctld, slurmd"
slurmctld -f "$SLURM_CONF"
slurmd -f "$SLURM_CONF"
for _ in $(seq 100); do
  [ -s "$work/slurmctld.pid" ] && [ -s "$work/slurmd.pid" ] && sinfo -h -o %T 2>/dev/null | grep -q idle && break
  sleep 0.2
done
echo "slurmctld pid $(cat "$work/slurmctld.pid"), slurmd pid $(cat "$work/slurmd.pid")"
sinfo
echo "== the README's job array, 4 shards"
cd "$work"
cp "$spec" spec.toml
for urdf in $(grep -oE '"[^"]+\.urdf"' spec.toml | tr -d '"' | sort -u); do cp "$(dirname "$spec")/$urdf" .; done
cat >array.sh <<JOB
#!/bin/bash
#SBATCH --job-name=tumble-dataset
#SBATCH --array=1-4
#SBATCH --cpus-per-task=1
#SBATCH --requeue
#SBATCH --signal=TERM@120            # SIGTERM 2 min before the time limit: in-flight chunks finish
#SBATCH --output=$work/array_%a.log
srun $tumble dataset spec.toml --out shards/\$SLURM_ARRAY_TASK_ID \\
    --shard \$SLURM_ARRAY_TASK_ID/\$SLURM_ARRAY_TASK_COUNT --threads \$SLURM_CPUS_PER_TASK --resume --quiet
JOB
cat array.sh
array=$(sbatch --parsable --chdir="$work" array.sh)
merge=$(sbatch --parsable --chdir="$work" --dependency=afterok:"$array" --output="$work/merge.log" \
  --wrap "$tumble dataset merge shards/1 shards/2 shards/3 shards/4 --out merged")
echo "submitted array job $array and merge job $merge (afterok:$array)"
for _ in $(seq 1200); do
  [ -z "$(squeue -h -j "$array,$merge" 2>/dev/null)" ] && break
  sleep 0.5
done
squeue
for k in 1 2 3 4; do echo "-- shard $k: $(tail -1 "array_$k.log" 2>/dev/null)"; done
echo "-- merge: $(tail -1 merge.log 2>/dev/null)"
[ -f merged/manifest.json ] || { echo "FAIL: no merged dataset"; cat slurmctld.log | tail -20; exit 1; }
echo "== the unsharded dataset, and byte identity"
"$tumble" dataset spec.toml --out unsharded --quiet | tail -1
files=$(cd unsharded && find . -type f | sort)
[ "$files" = "$(cd merged && find . -type f | sort)" ] || { echo "FAIL: the file lists differ"; exit 1; }
n=0
for f in $files; do
  cmp -s "unsharded/$f" "merged/$f" || { echo "FAIL: $f differs"; exit 1; }
  n=$((n + 1))
done
echo "OK: merged shards = unsharded dataset, $n files byte for byte identical"
