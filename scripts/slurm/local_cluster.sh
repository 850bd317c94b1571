#!/usr/bin/env bash
# A single-node Slurm cluster on localhost, for tests and trying the scripts here:
#   local_cluster.sh start DIR   writes DIR/slurm.conf, starts munged, slurmctld and slurmd
#                                (their pids in DIR/*.pid, logs in DIR/*.log) and waits
#                                until the node takes jobs; prints `export SLURM_CONF=…`.
#   local_cluster.sh stop DIR    stops the daemons it started, by pid.
# Needs Debian's slurm-wlm and munge (slurmctld, slurmd, munged on PATH) and root (the
# daemons run as the calling user; no cgroups: proctrack/linuxproc, task/none).
set -euo pipefail

cmd=${1:?usage: local_cluster.sh start|stop DIR}
dir=$(mkdir -p "${2:?usage: local_cluster.sh start|stop DIR}" && cd "$2" && pwd)
PATH=$PATH:/usr/sbin:/sbin

stop() {
    for d in slurmd slurmctld munged; do
        if [ -s "$dir/$d.pid" ]; then
            pid=$(cat "$dir/$d.pid")
            kill "$pid" 2>/dev/null || true
            for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
            kill -9 "$pid" 2>/dev/null || true
            rm -f "$dir/$d.pid"
        fi
    done
}

logs() {
    for f in "$dir"/*.log; do
        [ -f "$f" ] && { echo "--- $f"; tail -n 40 "$f"; }
    done
}

# A free TCP port (the kernel's pick), so that a test never meets another cluster's daemons.
free_port() {
    python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'
}

case "$cmd" in
stop)
    stop
    ;;
start)
    mkdir -p "$dir/state" "$dir/spool" "$dir/munge"
    chmod 700 "$dir/munge"
    # A key of our own: the system's key, if any, is left alone.
    [ -f "$dir/munge/munge.key" ] || head -c 1024 /dev/urandom >"$dir/munge/munge.key"
    chmod 600 "$dir/munge/munge.key"
    user=$(id -un)
    cpus=$(nproc)
    cat >"$dir/slurm.conf" <<CONF
ClusterName=lumen-local
SlurmctldHost=localhost
SlurmctldPort=$(free_port)
SlurmdPort=$(free_port)
SlurmUser=$user
SlurmdUser=$user
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$dir/munge/munge.socket
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
SchedulerType=sched/builtin
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
MpiDefault=none
ReturnToService=2
SlurmdTimeout=30
NodeName=localhost NodeHostname=localhost CPUs=$cpus State=UNKNOWN
PartitionName=local Nodes=localhost Default=YES MaxTime=INFINITE State=UP OverSubscribe=YES
CONF
    export SLURM_CONF=$dir/slurm.conf
    munged --force --socket="$dir/munge/munge.socket" --key-file="$dir/munge/munge.key" \
        --pid-file="$dir/munged.pid" --log-file="$dir/munged.log" --seed-file="$dir/munge/seed"
    slurmctld -f "$SLURM_CONF"
    slurmd -f "$SLURM_CONF" -N localhost
    # Ready when the node is idle (or mixed); give up after 60 s with the logs.
    for _ in $(seq 120); do
        state=$(sinfo -h -N -o %T 2>/dev/null || true)
        case "$state" in
        idle* | mixed*)
            echo "export SLURM_CONF=$SLURM_CONF"
            exit 0
            ;;
        esac
        sleep 0.5
    done
    echo "the local Slurm cluster did not come up (node state: ${state:-none})" >&2
    logs >&2
    stop
    exit 1
    ;;
logs)
    logs
    ;;
*)
    echo "usage: local_cluster.sh start|stop|logs DIR" >&2
    exit 2
    ;;
esac
