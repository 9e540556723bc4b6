#!/usr/bin/env bash
# A single-node Slurm on this machine, without systemd: for testing the Slurm
# executor (`repro figure ... --executor slurm`) and for running figures on a
# workstation through Slurm. Needs root (Debian/Ubuntu: slurm-wlm 22.05 or later).
#
#   scripts/slurm-local.sh start    install if absent, write slurm.conf, start
#                                   munged, slurmctld and slurmd; wait until the
#                                   node is idle
#   scripts/slurm-local.sh stop     stop the three daemons, remove their pid files
#   scripts/slurm-local.sh status   exit 0 if the node accepts jobs
#   scripts/slurm-local.sh check    run a trivial sbatch job and wait for it
#
# The node is called `localhost` and has this machine's CPUs and memory (from
# `slurmd -C`). There is no slurmdbd: read job states with squeue and
# `scontrol show job` (kept for MinJobAge = 1 h after a job ends), not sacct.
set -euo pipefail

CONF_DIR=${SLURM_CONF_DIR:-/etc/slurm}
CONF=$CONF_DIR/slurm.conf
LOG_DIR=/var/log/slurm
RUN_DIR=/run/slurm-local
CTLD_PID=$RUN_DIR/slurmctld.pid
SLURMD_PID=$RUN_DIR/slurmd.pid
MUNGE_PID=/run/munge/munged.pid

say() { echo "slurm-local: $*" >&2; }
die() { say "$*"; exit 1; }

need_root() { [ "$(id -u)" = 0 ] || die "must run as root (it starts system daemons)"; }

install_if_absent() {
    if command -v slurmctld >/dev/null && command -v slurmd >/dev/null \
        && command -v sbatch >/dev/null && command -v munged >/dev/null; then
        return
    fi
    command -v apt-get >/dev/null || die "slurmctld/slurmd/sbatch/munged missing and no apt-get to install them"
    say "installing slurmctld slurmd slurm-client munge"
    DEBIAN_FRONTEND=noninteractive apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq slurmctld slurmd slurm-client munge >/dev/null
}

write_conf() {
    mkdir -p "$CONF_DIR" "$LOG_DIR" "$RUN_DIR" /var/spool/slurmctld /var/spool/slurmd
    # The node line as slurmd sees the hardware: real CPU count and memory.
    local node
    node=$(slurmd -C | head -n1 | sed 's/^NodeName=[^ ]*/NodeName=localhost/')
    cat >"$CONF" <<CONF
# Written by scripts/slurm-local.sh: one node, this machine.
ClusterName=repro-local
SlurmctldHost=localhost
SlurmUser=root
AuthType=auth/munge
StateSaveLocation=/var/spool/slurmctld
SlurmdSpoolDir=/var/spool/slurmd
SlurmctldPidFile=$CTLD_PID
SlurmdPidFile=$SLURMD_PID
SlurmctldLogFile=$LOG_DIR/slurmctld.log
SlurmdLogFile=$LOG_DIR/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
# Memory is enforced by polling the job's processes (no cgroups here).
JobAcctGatherType=jobacct_gather/linux
JobAcctGatherFrequency=2
JobAcctGatherParams=OverMemoryKill
SchedulerType=sched/backfill
ReturnToService=2
MinJobAge=3600
KillWait=5
OverTimeLimit=0
InactiveLimit=0
MpiDefault=none
$node State=UNKNOWN
PartitionName=local Nodes=localhost Default=YES MaxTime=INFINITE State=UP
CONF
}

start_munge() {
    if [ -f "$MUNGE_PID" ] && kill -0 "$(cat "$MUNGE_PID")" 2>/dev/null; then return; fi
    rm -f "$MUNGE_PID" /run/munge/munge.socket.2*
    if [ ! -s /etc/munge/munge.key ]; then
        say "creating /etc/munge/munge.key"
        dd if=/dev/urandom bs=1 count=1024 of=/etc/munge/munge.key status=none
    fi
    chown munge:munge /etc/munge/munge.key
    chmod 400 /etc/munge/munge.key
    mkdir -p /run/munge /var/log/munge /var/lib/munge
    chown munge:munge /run/munge /var/log/munge /var/lib/munge
    runuser -u munge -- /usr/sbin/munged
}

# Kill the daemon named by a pid file, if it runs; remove the pid file either way.
stop_pidfile() {
    local f=$1 pid
    if [ -f "$f" ]; then
        pid=$(cat "$f")
        if kill -0 "$pid" 2>/dev/null; then
            kill "$pid"
            for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
            kill -0 "$pid" 2>/dev/null && kill -9 "$pid"
        fi
        rm -f "$f"
    fi
}

node_state() { sinfo -h -N -n localhost -o %T 2>/dev/null | head -n1; }

ready() { case "$(node_state)" in idle|mixed|allocated|completing) return 0;; *) return 1;; esac; }

start() {
    need_root
    install_if_absent
    if ready; then say "already running ($(node_state))"; return; fi
    # Stale daemons or pid files from an earlier run.
    stop_pidfile "$SLURMD_PID"
    stop_pidfile "$CTLD_PID"
    write_conf
    start_munge
    slurmctld
    slurmd -N localhost
    for _ in $(seq 120); do
        if ready; then say "node localhost $(node_state)"; return; fi
        case "$(node_state)" in
            down*|drain*) scontrol update NodeName=localhost State=RESUME 2>/dev/null || true;;
        esac
        sleep 0.5
    done
    say "node not ready after 60 s: state '$(node_state)'; see $LOG_DIR/slurmctld.log and slurmd.log"
    exit 1
}

stop() {
    need_root
    stop_pidfile "$SLURMD_PID"
    stop_pidfile "$CTLD_PID"
    stop_pidfile "$MUNGE_PID"
    say "stopped"
}

status() {
    if ready; then say "node localhost $(node_state)"; else say "not running"; exit 1; fi
}

check() {
    ready || die "not running (scripts/slurm-local.sh start)"
    local out id state
    out=$(mktemp)
    id=$(sbatch --parsable -o "$out" -t 1 --mem=10 --wrap 'echo slurm-local-ok')
    for _ in $(seq 120); do
        state=$(scontrol show job "$id" 2>/dev/null | sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p')
        case "$state" in
            COMPLETED) break;;
            FAILED|CANCELLED|TIMEOUT|NODE_FAIL|OUT_OF_MEMORY) die "job $id ended $state";;
        esac
        sleep 0.5
    done
    grep -q slurm-local-ok "$out" || die "job $id: state '$state', no output in $out"
    rm -f "$out"
    say "job $id ran"
}

case "${1:-}" in
    start) start;;
    stop) stop;;
    status) status;;
    check) check;;
    *) echo "usage: $0 start|stop|status|check" >&2; exit 2;;
esac
