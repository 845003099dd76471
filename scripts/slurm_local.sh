#!/usr/bin/env bash
# A one-node Slurm on this machine, for CI's sweep stage (and for trying --slurm at home):
#   scripts/slurm_local.sh start DIR   munged, slurmctld and slurmd from a config in DIR,
#                                      bound to 127.0.0.1; prints `export SLURM_CONF=...`
#   scripts/slurm_local.sh stop DIR    stops the three by their PID files
# Needs root and Debian's slurm-wlm and munge (scripts/setup.sh installs them when asked).
# Where a daemon does not start it says which and shows its log's tail, and exits 1: a
# stage that needs a cluster must not pass without one.
set -euo pipefail

action=${1:-}
dir=${2:-}
if [[ -z "$action" || -z "$dir" ]]; then
  echo "usage: $0 start|stop DIR" >&2
  exit 2
fi

stop_pid_file() {
  local file=$1
  [[ -f "$file" ]] || return 0
  local pid
  pid=$(cat "$file")
  if kill "$pid" 2>/dev/null; then
    for _ in $(seq 100); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    if kill -0 "$pid" 2>/dev/null; then
      echo "slurm_local: $file: $pid outlived SIGTERM by 10 s, killed" >&2
      kill -9 "$pid" 2>/dev/null || true
    fi
  fi
  rm -f "$file"
}

if [[ "$action" == stop ]]; then
  stop_pid_file "$dir/slurmd.pid"
  stop_pid_file "$dir/slurmctld.pid"
  stop_pid_file "$dir/munged.pid"
  echo "slurm_local: stopped the daemons of $dir"
  exit 0
fi
[[ "$action" == start ]] || { echo "usage: $0 start|stop DIR" >&2; exit 2; }

fail() {
  echo "slurm_local: $1" >&2
  [[ -n "${2:-}" && -f "$2" ]] && tail -n 20 "$2" >&2
  exit 1
}
[[ $(id -u) == 0 ]] || fail "needs root (slurmd runs jobs as their users)"
for program in munged slurmctld slurmd sbatch squeue; do
  command -v "$program" > /dev/null || fail "$program is not installed (apt-get install slurm-wlm munge)"
done
mkdir -p "$dir/state" "$dir/spool" "$dir/munge"
dir=$(cd "$dir" && pwd)
chmod 755 "$dir"  # munged runs as munge and must reach its folder (mktemp -d makes 0700)
chown munge:munge "$dir/munge"
if [[ ! -f /etc/munge/munge.key ]]; then  # the package makes one; a stripped image may not
  runuser -u munge -- mungekey -c -k /etc/munge/munge.key || fail "no /etc/munge/munge.key, and mungekey could not make one"
fi

# munged as the munge user, its socket in DIR (Slurm is told where: AuthInfo).
socket="$dir/munge/munge.socket"
runuser -u munge -- munged --socket="$socket" --pid-file="$dir/munge/munged.pid" \
  --log-file="$dir/munge/munged.log" --seed-file="$dir/munge/munged.seed" ||
  fail "munged did not start" "$dir/munge/munged.log"
cp "$dir/munge/munged.pid" "$dir/munged.pid"

cpus=$(nproc)
memory_mb=$(($(awk '/MemTotal/ {print $2}' /proc/meminfo) / 1024 * 9 / 10))
cat > "$dir/slurm.conf" << EOF
# A one-node cluster on 127.0.0.1 (scripts/slurm_local.sh).
ClusterName=hapvox
SlurmctldHost=$(hostname -s)(127.0.0.1)
MailProg=/bin/true
SlurmUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$socket
CommunicationParameters=NoInAddrAny,NoCtldInAddrAny
SlurmctldPort=${SLURMCTLD_PORT:-6817}
SlurmdPort=${SLURMD_PORT:-6818}
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
ProctrackType=proctrack/pgid
TaskPlugin=task/none
SwitchType=switch/none
MpiDefault=none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
JobCompType=jobcomp/none
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
ReturnToService=2
# Short intervals: a CI job is scheduled and cleared within seconds.
SchedulerParameters=sched_interval=1,batch_sched_delay=0
MessageTimeout=10
MinJobAge=60
NodeName=hapvox-node NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$memory_mb State=UNKNOWN
PartitionName=hapvox Nodes=hapvox-node Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF="$dir/slurm.conf"
slurmctld -f "$SLURM_CONF" || fail "slurmctld did not start" "$dir/slurmctld.log"
slurmd -f "$SLURM_CONF" -N hapvox-node || fail "slurmd did not start" "$dir/slurmd.log"
# Up when the node is idle.
for _ in $(seq 100); do
  if timeout 5 sinfo -h -N -o %t 2> /dev/null | grep -qx idle; then
    echo "export SLURM_CONF=$SLURM_CONF"
    exit 0
  fi
  sleep 0.2
done
timeout 5 sinfo -N >&2 || true
fail "the node did not come up idle within 20 s" "$dir/slurmd.log"
