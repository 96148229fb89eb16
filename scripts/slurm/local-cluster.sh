#!/usr/bin/env bash
# A single-node Slurm on localhost from Debian's packages, for trying the sharded-bake
# scripts (and for the optional test crates/probe-cli/tests/slurm.rs). Run as root:
#
#   apt-get install -y slurm-wlm          # Debian 12: Slurm 22.05, munge
#   scripts/slurm/local-cluster.sh start  # writes /etc/slurm/slurm.conf, starts munged,
#                                         # slurmctld and slurmd; waits until the node is idle
#   scripts/slurm/local-cluster.sh stop   # stops the three daemons (by their pid files)
#
# It writes /etc/slurm/slurm.conf only when none exists (a real cluster's is left alone). No
# cgroups, no accounting database: proctrack/linuxproc and task/none work in containers.
set -euo pipefail

run_dir=/run/probes-slurm
conf=/etc/slurm/slurm.conf

start() {
    command -v slurmctld >/dev/null || { echo "slurmctld not found: apt-get install -y slurm-wlm" >&2; exit 1; }
    mkdir -p "$run_dir" /var/spool/slurmctld /var/spool/slurmd /var/log/slurm /etc/slurm
    host=$(hostname -s)
    cpus=$(nproc)
    # Leave 1 GiB to the system; slurmd refuses a node with less memory than configured.
    memory=$(( $(awk '/MemTotal/ {print int($2 / 1024)}' /proc/meminfo) - 1024 ))
    if [ ! -e "$conf" ]; then
        cat > "$conf" <<CONF
# Written by probes scripts/slurm/local-cluster.sh: one node, localhost.
ClusterName=probes-local
SlurmctldHost=$host
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
StateSaveLocation=/var/spool/slurmctld
SlurmdSpoolDir=/var/spool/slurmd
SlurmctldPidFile=$run_dir/slurmctld.pid
SlurmdPidFile=$run_dir/slurmd.pid
SlurmctldLogFile=/var/log/slurm/slurmctld.log
SlurmdLogFile=/var/log/slurm/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MpiDefault=none
NodeName=$host CPUs=$cpus RealMemory=$memory State=UNKNOWN
PartitionName=local Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
    fi
    if [ ! -s /etc/munge/munge.key ]; then
        mkdir -p /etc/munge
        dd if=/dev/urandom of=/etc/munge/munge.key bs=1024 count=1 status=none
    fi
    chown munge:munge /etc/munge/munge.key 2>/dev/null || true
    chmod 400 /etc/munge/munge.key
    mkdir -p /run/munge /var/lib/munge /var/log/munge
    chown munge:munge /run/munge /var/lib/munge /var/log/munge 2>/dev/null || true
    # munged writes its pid to /run/munge/munged.pid.
    if ! munge -n >/dev/null 2>&1; then
        runuser -u munge -- /usr/sbin/munged
    fi
    for _ in $(seq 50); do munge -n >/dev/null 2>&1 && break; sleep 0.1; done
    munge -n | unmunge >/dev/null
    pgrep -x slurmctld >/dev/null || slurmctld
    pgrep -x slurmd >/dev/null || slurmd
    for _ in $(seq 100); do
        state=$(sinfo -h -N -o '%t' 2>/dev/null | head -n1 || true)
        case "$state" in idle|mix|alloc) echo "slurm up on $host: node $state"; return 0 ;; esac
        sleep 0.2
    done
    echo "slurm did not come up (node state: ${state:-none}); see /var/log/slurm/*.log" >&2
    exit 1
}

stop() {
    for daemon in slurmd slurmctld; do
        if [ -s "$run_dir/$daemon.pid" ]; then kill "$(cat "$run_dir/$daemon.pid")" 2>/dev/null || true; fi
    done
    if [ -s /run/munge/munged.pid ]; then kill "$(cat /run/munge/munged.pid)" 2>/dev/null || true; fi
}

case "${1:-}" in
    start) start ;;
    stop) stop ;;
    *) echo "usage: $0 start|stop" >&2; exit 2 ;;
esac
