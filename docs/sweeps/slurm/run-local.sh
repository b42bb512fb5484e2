#!/usr/bin/env bash
# The documented Slurm job array (docs/sweeps/slurm.sbatch), run for real on a single-node Slurm
# started on this machine: Debian's slurm-wlm and munge (installed if missing; root), one node
# with every core, the array submitted with `sbatch --array`, waited for, merged with
# `vio sweep-merge`, and compared byte for byte with the same sweep run in one process.
#
#   bash docs/sweeps/slurm/run-local.sh [SWEEP.toml] [SHARDS]
#
# Defaults: scenarios/sweeps/focal_error.toml, 2 shards. Needs target/release/vio (cargo build
# --release -p scenarios --bin vio). Prints the job id, each task's state and the cmp result;
# exits 1 when the merged sweep differs. Leaves slurmctld/slurmd running only while it runs.
set -euo pipefail
cd "$(dirname "$0")/../../.."
sweep=${1:-scenarios/sweeps/focal_error.toml}
shards=${2:-2}
vio=target/release/vio
[ -x "$vio" ] || { echo "build $vio first" >&2; exit 2; }
[ "$(id -u)" = 0 ] || { echo "run as root (it configures and starts slurmctld, slurmd, munged)" >&2; exit 2; }

if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends slurm-wlm munge
fi

work=$(mktemp -d /tmp/vio-slurm-XXXX)
host=$(hostname -s)
cpus=$(nproc)
mem=$(( $(awk '/MemTotal/ {print $2}' /proc/meminfo) / 1024 - 1024 ))

# munge: a key of its own, the daemon on a private socket folder.
mkdir -p /etc/munge /var/run/munge /var/log/munge /var/lib/munge
[ -s /etc/munge/munge.key ] || dd if=/dev/urandom of=/etc/munge/munge.key bs=1024 count=1 status=none
chown -R munge:munge /etc/munge /var/run/munge /var/log/munge /var/lib/munge 2>/dev/null || true
chmod 400 /etc/munge/munge.key
pgrep -x munged >/dev/null || runuser -u munge -- /usr/sbin/munged

# One node, one partition; no cgroups (containers rarely allow them), root as the Slurm user.
mkdir -p "$work/spool" "$work/state" /etc/slurm
cat > /etc/slurm/slurm.conf <<CONF
ClusterName=vio-local
SlurmctldHost=$host
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/slurmctld.log
SlurmdLogFile=$work/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
MpiDefault=none
NodeName=$host CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=local Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
cleanup() {
  pkill -x slurmd 2>/dev/null || true
  pkill -x slurmctld 2>/dev/null || true
}
trap cleanup EXIT
slurmctld -i
slurmd
for _ in $(seq 60); do
  sinfo -h -o %T 2>/dev/null | grep -qE "idle|mixed" && break
  sleep 1
done
sinfo

# The documented job array, one CPU per task so that every shard fits on this node.
rm -rf target/slurm-check
mkdir -p target/slurm-check
start=$SECONDS
job=$(VIO_SWEEP="$sweep" VIO_SWEEP_OUT=target/slurm-check sbatch --parsable --wait \
  --array=0-$((shards - 1)) --cpus-per-task=1 --output=target/slurm-check/slurm-%A_%a.log \
  docs/sweeps/slurm.sbatch)
echo "job $job finished after $((SECONDS - start)) s"
sacct -j "$job" -n -o JobID,State,ExitCode 2>/dev/null || scontrol show job "$job" | grep -E "JobId|JobState" || true
"$vio" sweep-merge target/slurm-check/shard-* --out target/slurm-check/merged

# The same sweep in one process; the two folders must hold the same bytes.
"$vio" sweep "$sweep" --out target/slurm-check/single --jobs "$cpus" >/dev/null
if diff -r target/slurm-check/merged target/slurm-check/single >/dev/null; then
  for f in $(cd target/slurm-check/single && find . -type f | sort); do
    cmp "target/slurm-check/merged/$f" "target/slurm-check/single/$f"
  done
  echo "cmp: merged Slurm array == single process ($(find target/slurm-check/single -type f | wc -l) files identical)"
else
  diff -rq target/slurm-check/merged target/slurm-check/single || true
  echo "cmp: the merged Slurm sweep differs from the single-process one" >&2
  exit 1
fi
