#!/usr/bin/env bash
# A one-node Slurm cluster on this machine, for trying lash's sharded sweeps
# (scripts/slurm/run-map.sh). Debian/Ubuntu, run as root. Not part of CI.
#
#   sudo bash scripts/slurm/setup-localhost.sh      # install, configure, start
#   sinfo                                            # the node "idle" in partition "lash"
#
# Installs Debian's slurm-wlm and munge, writes /etc/slurm/slurm.conf for this host (all its
# cores, process tracking by process group, no cgroups, no accounting), creates a munge key
# if there is none, and starts munged, slurmctld and slurmd in the background (no systemd
# needed). Run it again to restart them.
set -euo pipefail
if [ "$(id -u)" != 0 ]; then
    echo "run as root (sudo bash $0)" >&2
    exit 2
fi
export DEBIAN_FRONTEND=noninteractive
command -v slurmctld >/dev/null || { apt-get update -q && apt-get install -y -q slurm-wlm munge; }

host=$(hostname -s)
cpus=$(nproc)
mem=$(awk '/MemTotal/ { printf "%d", $2 / 1024 * 0.9 }' /proc/meminfo)
mkdir -p /etc/slurm /var/spool/slurmctld /var/spool/slurmd /var/log/slurm /run/munge
cat > /etc/slurm/slurm.conf <<CONF
ClusterName=lash-localhost
SlurmctldHost=${host}
SlurmUser=root
AuthType=auth/munge
ProctrackType=proctrack/pgid
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
ReturnToService=2
StateSaveLocation=/var/spool/slurmctld
SlurmdSpoolDir=/var/spool/slurmd
SlurmctldPidFile=/run/slurmctld.pid
SlurmdPidFile=/run/slurmd.pid
SlurmctldLogFile=/var/log/slurm/slurmctld.log
SlurmdLogFile=/var/log/slurm/slurmd.log
NodeName=${host} CPUs=${cpus} RealMemory=${mem} State=UNKNOWN
PartitionName=lash Nodes=${host} Default=YES MaxTime=INFINITE State=UP
CONF

# munge: a key, then the daemon.
if [ ! -s /etc/munge/munge.key ]; then
    if command -v mungekey >/dev/null; then mungekey --create --force; else create-munge-key -f; fi
fi
chown -R munge:munge /etc/munge /run/munge /var/lib/munge /var/log/munge 2>/dev/null || true
chmod 0700 /etc/munge
chmod 0400 /etc/munge/munge.key
pkill -x munged 2>/dev/null || true
su -s /bin/sh munge -c /usr/sbin/munged
sleep 1
munge -n | unmunge >/dev/null

# Slurm: controller and node daemon (restarted if running).
pkill -x slurmd 2>/dev/null || true
pkill -x slurmctld 2>/dev/null || true
sleep 1
slurmctld
slurmd
for _ in $(seq 30); do
    if sinfo -h -o %T 2>/dev/null | grep -q idle; then
        sinfo
        exit 0
    fi
    sleep 1
done
echo "the node did not become idle; see /var/log/slurm/slurmctld.log and slurmd.log" >&2
sinfo >&2 || true
exit 1
