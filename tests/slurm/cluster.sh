#!/usr/bin/env bash
# A one-node SLURM cluster on this machine, for tests/test_sweep_slurm.py.
#
#   cluster.sh start DIR   munged (if not running), slurmctld and slurmd on localhost, with
#                          DIR/slurm.conf; waits until the node is idle. Reuses a cluster
#                          already running from DIR.
#   cluster.sh stop DIR    stops the daemons `start` started (by the pids it recorded).
#
# Clients find the cluster with SLURM_CONF=DIR/slurm.conf. Needs root and Debian's
# slurm-wlm and munge. The settings are the ones Debian's slurm-wlm 22.05 accepts in a
# container without cgroups: process tracking through /proc, no task plugin, no
# cgroup.conf at all (that version has no CgroupPlugin=disabled).
set -euo pipefail

command=${1:?usage: cluster.sh start|stop DIR}
export PATH=$PATH:/usr/sbin:/sbin  # the daemons live in sbin, not always on a user's PATH
dir=$(realpath -m "${2:?usage: cluster.sh start|stop DIR}")
export SLURM_CONF=$dir/slurm.conf

node_state() {
    sinfo --noheader --nodes=localhost --format=%T 2>/dev/null || true
}

stop_pidfile() {  # stop_pidfile FILE: TERM the process, wait up to 10 s, then KILL it
    local pid
    [[ -s $1 ]] || return 0
    pid=$(<"$1")
    kill -TERM "$pid" 2>/dev/null || { rm -f "$1"; return 0; }
    for _ in $(seq 100); do
        kill -0 "$pid" 2>/dev/null || { rm -f "$1"; return 0; }
        sleep 0.1
    done
    kill -KILL "$pid" 2>/dev/null || true
    rm -f "$1"
}

start() {
    mkdir -p "$dir/state" "$dir/spool"
    if [[ -s $dir/slurmctld.pid ]] && kill -0 "$(<"$dir/slurmctld.pid")" 2>/dev/null \
            && [[ $(node_state) == idle* ]]; then
        return 0  # already up
    fi

    # munge authenticates every message between the daemons and the clients.
    if ! munge -n </dev/null 2>/dev/null | unmunge >/dev/null 2>&1; then
        if [[ ! -s /etc/munge/munge.key ]]; then
            mkdir -p /etc/munge
            dd if=/dev/urandom of=/etc/munge/munge.key bs=1024 count=1 status=none
            chown munge:munge /etc/munge/munge.key
            chmod 400 /etc/munge/munge.key
        fi
        mkdir -p /run/munge /var/lib/munge /var/log/munge
        chown munge:munge /run/munge /var/lib/munge /var/log/munge
        runuser -u munge -- munged --force  # --force: remove the socket of a munged that died
        cp /run/munge/munged.pid "$dir/munged.pid"  # started here, so stopped here
    fi

    # The node as slurmd sees it (CPUs, sockets, memory), renamed to localhost.
    local hardware
    hardware=$(slurmd -C | head -n 1 | sed 's/^NodeName=[^ ]*/NodeName=localhost/')
    cat >"$dir/slurm.conf" <<CONF
ClusterName=dronefleet-test
SlurmctldHost=localhost
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MpiDefault=none
ReturnToService=2
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
$hardware State=UNKNOWN
PartitionName=debug Nodes=localhost Default=YES MaxTime=INFINITE State=UP
CONF

    slurmctld -c -f "$SLURM_CONF"   # -c: a clean start, no state from an earlier cluster
    slurmd -N localhost -f "$SLURM_CONF"
    for _ in $(seq 120); do
        [[ $(node_state) == idle* ]] && return 0
        sleep 0.5
    done
    echo "cluster.sh: the node did not become idle within 60 s; logs in $dir" >&2
    tail -n 20 "$dir/slurmctld.log" "$dir/slurmd.log" >&2 || true
    return 1
}

stop() {
    stop_pidfile "$dir/slurmd.pid"
    stop_pidfile "$dir/slurmctld.pid"
    stop_pidfile "$dir/munged.pid"
}

case $command in
    start) start ;;
    stop) stop ;;
    *) echo "usage: cluster.sh start|stop DIR" >&2; exit 2 ;;
esac
