#!/usr/bin/env bash
# A penumbra sweep on a real scheduler (issue #53): a one-node Slurm cluster of its own (munged,
# slurmctld, slurmd: private key, sockets, ports, state and logs, all in the test's temporary
# folder; SLURM_CONF, nothing in /etc), the oracle traced once into a shared cache, then
# docs/slurm/sweep-array.sh submitted as it is as a job array (sbatch --array=1-N) and
# docs/slurm/merge.sh as a job that depends on it (afterok), as docs/sweep.md says. Checks: each
# shard ran as an array task (its slurm-task.txt against scontrol), the merge job completed,
# the merged sweep.csv equals one unsharded run on every verdict column (as sweep_test.sh), and
# after teardown no process of the cluster is left and the temporary folder is gone.
# Needs root and Debian's slurm-wlm and munge (scripts/install-deps.sh): without them it skips
# (exit 77), and with CI set a missing package is a failure.
# Usage: slurm_sweep_test.sh PENUMBRA SOURCE_DIR
set -uo pipefail
PATH=$PATH:/usr/sbin:/sbin  # the daemons, where a root shell's PATH lacks them
missing=()
for tool in munged mungekey munge unmunge slurmctld slurmd sbatch scontrol sinfo squeue scancel; do
    command -v "$tool" >/dev/null 2>&1 || missing+=("$tool")
done
if ((${#missing[@]})); then
    if [[ -n ${CI:-} ]]; then
        echo "FAIL: ${missing[*]} not installed (CI must run this test; scripts/install-deps.sh installs slurm-wlm and munge)"
        exit 1
    fi
    echo "SKIP: ${missing[*]} not installed (Debian's slurm-wlm and munge; scripts/install-deps.sh installs them)"
    exit 77
fi
if [[ $(id -u) -ne 0 ]]; then
    echo "SKIP: not running as root (the test's Slurm cluster runs its daemons as root, SlurmUser=root)"
    exit 77
fi
source "$(dirname "$0")/harness.sh"
fail_detail() { echo "(rc $rc: $(head -c 400 <<<"$err"))"; }
src=$(cd "$src" && pwd)
# munged wants every folder above its socket searchable by all; the key folder stays private.
chmod 711 "$tmp"
mkdir -p "$tmp"/{etc,munge,run,state,spool,log,work} && chmod 700 "$tmp/munge" && chmod 755 "$tmp/run"
export SLURM_CONF=$tmp/etc/slurm.conf
# Nothing outside $tmp: penumbra's oracle cache and Mesa's shader cache (in jobs too: sbatch
# passes this environment on).
export PENUMBRA_CACHE_DIR=$tmp/cache XDG_CACHE_HOME=$tmp/xdg-cache
torn_down=
declare -A pids=()
# Every live process of this cluster: its environment holds our SLURM_CONF (the daemons, their
# slurmstepd and slurmscriptd, the jobs), less this script's own descendants (sbatch, pgrep...).
cluster_processes() {
    local p q env
    for p in /proc/[0-9]*; do
        p=${p#/proc/}
        env=$( { tr '\0' '\n' <"/proc/$p/environ"; } 2>/dev/null) || continue
        grep -qxF "SLURM_CONF=$SLURM_CONF" <<<"$env" || continue
        q=$p
        while [[ -n $q && $q -gt 1 && $q -ne $$ ]]; do
            q=$(awk '{print $4}' "/proc/$q/stat" 2>/dev/null)
        done
        [[ $q == "$$" ]] || echo "$p"
    done
}
stop_pid() {  # stop_pid PID: TERM, up to 10 s, then KILL
    local i
    kill -TERM "$1" 2>/dev/null || return 0
    for i in $(seq 50); do kill -0 "$1" 2>/dev/null || return 0; sleep 0.2; done
    kill -KILL "$1" 2>/dev/null
}
teardown() {  # idempotent: the EXIT trap calls it again
    [[ -n $torn_down ]] && return 0
    torn_down=1
    local name p i
    if [[ -n ${pids[slurmctld]:-} ]] && kill -0 "${pids[slurmctld]}" 2>/dev/null; then
        timeout 10 scancel --quiet --user=root 2>/dev/null
        for i in $(seq 30); do
            [[ -z $(timeout 5 squeue -h -o %i 2>/dev/null) ]] && break
            sleep 0.5
        done
    fi
    # slurmd first (it ends its steps), munged last (the others' shutdown talks through it).
    for name in slurmd slurmctld munged; do
        p=${pids[$name]:-}
        [[ -z $p && -s $tmp/run/$name.pid ]] && p=$(cat "$tmp/run/$name.pid")
        [[ -n $p ]] && stop_pid "$p"
    done
    for p in $(cluster_processes); do stop_pid "$p"; done
}
trap 'teardown; chmod -R u+w "$tmp" 2>/dev/null; rm -rf "$tmp"' EXIT
trap 'exit 1' INT TERM
logs() {  # the daemons' and jobs' logs, on a failure
    local f
    for f in "$tmp"/munge/munged.log "$tmp"/log/*; do
        [[ -f $f ]] && { echo "--- $f"; tail -n 15 "$f"; }
    done
}
wait_for() {  # wait_for SECONDS COMMAND...: 0 once COMMAND succeeds, 1 after SECONDS
    local end=$((SECONDS + $1))
    shift
    until "$@"; do
        ((SECONDS >= end)) && return 1
        sleep 0.5
    done
}
pid_of() {  # pid_of NAME: waits for its pid file, records the pid
    wait_for 15 test -s "$tmp/run/$1.pid" || return 1
    pids[$1]=$(cat "$tmp/run/$1.pid")
    kill -0 "${pids[$1]}" 2>/dev/null
}
started() {  # started NAME: pid_of, else the logs and the end
    if ! pid_of "$1"; then
        check "$1 starts" false
        logs
        finish
        exit 1
    fi
}

# munge: a key and a socket of our own.
mungekey --create --keyfile="$tmp/munge/munge.key" || { echo "FAIL: mungekey"; exit 1; }
munged --key-file="$tmp/munge/munge.key" --socket="$tmp/run/munge.socket" --pid-file="$tmp/run/munged.pid" \
    --seed-file="$tmp/munge/munged.seed" --log-file="$tmp/munge/munged.log"
started munged
munge_ok() { timeout 5 munge -n -S "$tmp/run/munge.socket" | timeout 5 unmunge -S "$tmp/run/munge.socket" >/dev/null 2>&1; }
check "munged answers on its own socket" wait_for 10 munge_ok

# Slurm: free ports on 127.0.0.1, one node of nproc CPUs named as the host, a unique cluster name.
read -r ctld_port slurmd_port < <(python3 -c "
import socket
s = [socket.socket() for _ in range(2)]
for x in s: x.bind(('127.0.0.1', 0))
print(*[x.getsockname()[1] for x in s])")
node=$(hostname -s)
cpus=$(nproc)
cat >"$SLURM_CONF" <<EOF
ClusterName=penumbra-test-$$-$RANDOM
SlurmctldHost=$node(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$tmp/run/munge.socket
CredType=cred/munge
StateSaveLocation=$tmp/state
SlurmdSpoolDir=$tmp/spool
SlurmctldPidFile=$tmp/run/slurmctld.pid
SlurmdPidFile=$tmp/run/slurmd.pid
SlurmctldLogFile=$tmp/log/slurmctld.log
SlurmdLogFile=$tmp/log/slurmd.log
MailProg=/bin/true
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
DependencyParameters=kill_invalid_depend
NodeName=$node NodeAddr=127.0.0.1 CPUs=$cpus State=UNKNOWN
PartitionName=penumbra Nodes=$node Default=YES MaxTime=INFINITE State=UP
EOF
slurmctld
started slurmctld
slurmd -N "$node"
started slurmd
node_idle() { [[ $(timeout 5 sinfo -h -n "$node" -o %T 2>/dev/null) == idle ]]; }
check "the node comes up idle" wait_for 60 node_idle

# The scenario small (as sweep_test.sh), the oracle traced once into the shared cache.
sed -e 's/"width": 1280/"width": 240/' -e 's/"height": 720/"height": 136/' \
    -e 's#"scene.glb"#"'"$src"'/data/default/scene.glb"#' "$src/data/default/scenario.json" >"$tmp/a.json"
vary=(--vary resolution=256,512 --vary filter.type=none,pcf --repeat 1 -q)
shards=2
run validate "$tmp/a.json" --out "$tmp/validate" --cache "$tmp/cache" -q
check "validate traces the oracle into the cache" test -n "$(ls "$tmp/cache" 2>/dev/null)"
# A cache hit touches its entry (the least recently used go first) but never rewrites it: the
# entries' names, sizes and inodes (a new trace is written aside and renamed in) must not change.
cache_entries() { (cd "$tmp/cache" && stat -c '%n %s %i' -- * 2>/dev/null | sort); }
cache_before=$(cache_entries)

# docs/sweep.md's recipe: the array, then the merge once every task succeeded.
unset SHARDS
export PENUMBRA=$bin SCENARIO=$tmp/a.json OUT=$tmp/work/sweep CACHE=$tmp/cache
cd "$tmp/work" || exit 1
job=$(timeout 30 sbatch --parsable --array=1-$shards --output="$tmp/log/sweep-%A_%a.out" \
    "$src/docs/slurm/sweep-array.sh" "${vary[@]}" 2>"$tmp/log/sbatch.err")
rc=$?
err=$(cat "$tmp/log/sbatch.err")
job=${job%%;*}
check "sbatch --array submits docs/slurm/sweep-array.sh" test "$rc" -eq 0 -a -n "$job"
merge_job=$(timeout 150 sbatch --parsable --wait --dependency=afterok:"$job" --export=ALL,SHARDS=$shards \
    --output="$tmp/log/merge-%j.out" "$src/docs/slurm/merge.sh" -q 2>"$tmp/log/sbatch-merge.err")
rc=$?
err=$(cat "$tmp/log/sbatch-merge.err")
merge_job=${merge_job%%;*}
check "sbatch --wait on the merge job (afterok on the array) exits 0" test "$rc" -eq 0 -a -n "$merge_job"
cd "$tmp" || exit 1

# Each shard ran as its array task: slurm-task.txt names the job and task, and scontrol agrees.
tasks=$(timeout 10 scontrol -o show job "$job" 2>&1)
for k in $(seq 1 $shards); do
    d=$OUT-$k
    check "shard $k wrote its sweep" test -s "$d/sweep.csv"
    rec=$(cat "$d/slurm-task.txt" 2>/dev/null)
    check "shard $k ran as array task $k of job $job" grep -qE "^job=[0-9]+ array_job=$job task=$k shards=$shards node=$node\$" <<<"$rec"
    task_job=$(sed -n 's/^job=\([0-9]*\) .*/\1/p' <<<"$rec")
    check "scontrol: array task $k (job ${task_job:-?}) completed with exit 0" grep -qE \
        "^JobId=$task_job ArrayJobId=$job ArrayTaskId=$k .*JobState=COMPLETED .*ExitCode=0:0" <<<"$tasks"
done
check "scontrol: the merge job completed with exit 0" grep -qE "JobState=COMPLETED .*ExitCode=0:0" \
    <<<"$(timeout 10 scontrol -o show job "$merge_job" 2>&1)"
check "no shard traced the oracle again" test "$(cache_entries)" == "$cache_before"

# One unsharded run; the merged shards equal it on every verdict column.
run sweep "$tmp/a.json" --out "$tmp/one" --cache "$tmp/cache" "${vary[@]}"
check "one unsharded sweep exits 0" test "$rc" -eq 0
verdict() { cut -d, -f1-11 "$1"; }
check "the merged shards equal one run on every verdict column" cmp -s <(verdict "$tmp/one/sweep.csv") \
    <(verdict "$OUT/sweep.csv")
check "the merge wrote one run's files" test -s "$OUT/sweep.json" -a -s "$OUT/report.html"
check "the merge wrote a row per configuration" test "$(wc -l <"$OUT/sweep.csv" 2>/dev/null)" -eq 5
((failed)) && logs

# Teardown: every daemon and job of the cluster gone, then the folder.
teardown
for name in munged slurmctld slurmd; do
    check "$name (pid ${pids[$name]:-?}) is stopped" fails kill -0 "${pids[$name]:-0}" 2>/dev/null
done
left=$(cluster_processes)
check "no process of the cluster is left${left:+ (left: $(ps -o pid=,args= -p ${left//$'\n'/,}))}" test -z "$left"
cd / || exit 1
chmod -R u+w "$tmp" 2>/dev/null
rm -rf "$tmp"
check "the temporary folder is gone" test ! -e "$tmp"
finish
