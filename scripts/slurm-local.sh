#!/usr/bin/env bash
# A real one-node Slurm on this Debian machine, for hexbake's tests (facts in
# ../shared/SLURM.md): munged + slurmctld + slurmd under a state directory, no systemd.
#
#   scripts/slurm-local.sh start [STATE_DIR]   # installs slurm-wlm + munge if missing
#   scripts/slurm-local.sh stop  [STATE_DIR]
#   scripts/slurm-local.sh env   [STATE_DIR]   # prints `export SLURM_CONF=...`
#
# STATE_DIR defaults to /tmp/hexbake-slurm. Clients need SLURM_CONF=STATE_DIR/slurm.conf.
set -euo pipefail

cmd=${1:-}
state=${2:-/tmp/hexbake-slurm}
conf=$state/slurm.conf

die() { echo "slurm-local: $*" >&2; exit 1; }
sudo_if() { if [ "$(id -u)" = 0 ]; then "$@"; else sudo "$@"; fi; }

install_packages() {
    command -v slurmctld >/dev/null && command -v munged >/dev/null && return
    # Keep the packages' postinst from starting system daemons.
    if [ ! -e /usr/sbin/policy-rc.d ]; then
        printf '#!/bin/sh\nexit 101\n' | sudo_if tee /usr/sbin/policy-rc.d >/dev/null
        sudo_if chmod +x /usr/sbin/policy-rc.d
    fi
    sudo_if apt-get install -y -qq --no-install-recommends -o DPkg::Lock::Timeout=600 slurm-wlm munge >/dev/null 2>&1 || {
        sudo_if apt-get update -qq
        sudo_if apt-get install -y -qq --no-install-recommends -o DPkg::Lock::Timeout=600 slurm-wlm munge >/dev/null
    } || die "cannot install slurm-wlm and munge with apt-get"
}

alive() { [ -f "$1" ] && kill -0 "$(cat "$1")" 2>/dev/null && ! grep -q '^State:.*Z' "/proc/$(cat "$1")/status" 2>/dev/null; }

stop() {
    for d in slurmd slurmctld munged; do
        pidf=$state/$d.pid
        if alive "$pidf"; then
            kill "$(cat "$pidf")" 2>/dev/null || true
            for _ in $(seq 50); do alive "$pidf" || break; sleep 0.1; done
            alive "$pidf" && kill -9 "$(cat "$pidf")" 2>/dev/null || true
        fi
        rm -f "$pidf"
    done
}

start() {
    install_packages
    stop
    mkdir -p "$state"/{munge,spool,slurmd,log}
    chmod 700 "$state/munge"
    host=$(hostname -s)

    # 1. munge with its own key and socket.
    [ -f "$state/munge/munge.key" ] || mungekey --create --keyfile="$state/munge/munge.key" >/dev/null 2>&1
    chmod 600 "$state/munge/munge.key"
    munged --key-file="$state/munge/munge.key" --socket="$state/munge/munge.socket" \
        --pid-file="$state/munged.pid" --log-file="$state/log/munged.log" \
        --seed-file="$state/munge/munge.seed" --force
    for _ in $(seq 50); do [ -S "$state/munge/munge.socket" ] && break; sleep 0.1; done

    # 2. slurm.conf with the node line from `slurmd -C`.
    node=$(slurmd -C 2>/dev/null | head -1 | sed "s/NodeName=[^ ]*/NodeName=$host/")
    cat >"$conf" <<CONF
ClusterName=hexbake
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$state/munge/munge.socket
CredType=cred/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/filetxt
JobCompLoc=$state/log/jobcomp.txt
MailProg=/bin/true
ReturnToService=2
MinJobAge=3600
DependencyParameters=kill_invalid_depend
StateSaveLocation=$state/spool
SlurmdSpoolDir=$state/slurmd
SlurmctldPidFile=$state/slurmctld.pid
SlurmdPidFile=$state/slurmd.pid
SlurmctldLogFile=$state/log/slurmctld.log
SlurmdLogFile=$state/log/slurmd.log
SlurmctldPort=6817
SlurmdPort=6818
SchedulerType=sched/backfill
$node NodeAddr=127.0.0.1 State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF

    # 3. The daemons; wait until the node is idle.
    export SLURM_CONF=$conf
    slurmctld -c -f "$conf"
    slurmd -N "$host" -f "$conf"
    for _ in $(seq 100); do
        sinfo -h -o %T 2>/dev/null | grep -qx idle && { echo "slurm-local: up ($conf)"; return; }
        sleep 0.2
    done
    tail -5 "$state/log/slurmctld.log" "$state/log/slurmd.log" >&2 || true
    die "the node did not become idle (logs above)"
}

case $cmd in
    start) start ;;
    stop) stop; echo "slurm-local: stopped" ;;
    env) echo "export SLURM_CONF=$conf" ;;
    *) die "usage: $0 start|stop|env [STATE_DIR]" ;;
esac
