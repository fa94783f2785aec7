#!/bin/sh
# Integration test of granulard's Slurm launcher against a real single-machine Slurm (munged, slurmctld, slurmd on loopback).
set -u
. "$(dirname "$0")/daemon_lib.sh"
: "${GRANULARCTL:=$BUILDDIR/client/granularctl}"

# ---- a Slurm of our own, in $tmp/slurm -----------------------------------------
need=""
for p in munged slurmctld slurmd sbatch srun squeue scontrol scancel sinfo; do
	command -v "$p" >/dev/null 2>&1 || need="$need $p"
done
if [ -n "$need" ]; then
	echo "1..0 # SKIP Slurm cannot start: missing$need (./quickstart check installs slurm-wlm and munge)"
	exit 0
fi
if [ "$(id -u)" != 0 ]; then
	echo "1..0 # SKIP Slurm cannot start: slurmd must run as root to start jobs (SlurmdUser=root)"
	exit 0
fi
D=$tmp/slurm
mkdir -p "$D/spool" "$D/ctld" "$D/log" "$D/run"
chmod 700 "$tmp" "$D"
SLURM_CONF=$D/slurm.conf
export SLURM_CONF
slurm_stop() {
	scancel --full --signal=KILL --user="$(id -un)" 2>/dev/null
	for f in slurmd slurmctld munged; do
		p=$(cat "$D/run/$f.pid" 2>/dev/null) && [ -n "$p" ] && kill "$p" 2>/dev/null
	done
	sleep 0.5
	for f in slurmd slurmctld munged; do
		p=$(cat "$D/run/$f.pid" 2>/dev/null) && [ -n "$p" ] && kill -9 "$p" 2>/dev/null
	done
}
trap 'slurm_stop; cleanup' EXIT
skip_all() {
	echo "1..0 # SKIP Slurm cannot start: $1"
	for f in "$D"/log/*.log; do echo "# --- $f"; tail -n 5 "$f" | sed 's/^/# /'; done
	exit 0
}
# Two free TCP ports on loopback for slurmctld and slurmd.
set -- $(/usr/bin/python3 -c 'import socket
s=[socket.socket() for _ in range(2)]
[x.bind(("127.0.0.1", 0)) for x in s]
print(*[x.getsockname()[1] for x in s])')
CTLD_PORT=$1 SLURMD_PORT=$2
dd if=/dev/urandom of="$D/munge.key" bs=1024 count=1 2>/dev/null && chmod 600 "$D/munge.key"
munged -f --key-file="$D/munge.key" --socket="$D/run/munge.sock" --pid-file="$D/run/munged.pid" \
	--log-file="$D/log/munged.log" --seed-file="$D/run/munge.seed" 2>"$D/log/munged.err" ||
	skip_all "munged did not start ($(head -n 1 "$D/log/munged.err"))"
host=$(hostname -s)
# A container's root: no cgroups, no accounting; 4 CPUs whatever the machine has (config_overrides), so
# that a 2-rank job and a blocker fit.
cat >"$SLURM_CONF" <<EOF
ClusterName=granulardtest
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$CTLD_PORT
SlurmdPort=$SLURMD_PORT
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$D/run/munge.sock
SlurmUser=root
SlurmdUser=root
StateSaveLocation=$D/ctld
SlurmdSpoolDir=$D/spool
SlurmctldPidFile=$D/run/slurmctld.pid
SlurmdPidFile=$D/run/slurmd.pid
SlurmctldLogFile=$D/log/slurmctld.log
SlurmdLogFile=$D/log/slurmd.log
SlurmdParameters=config_overrides
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
MpiDefault=none
ReturnToService=2
InactiveLimit=0
MinJobAge=300
KillWait=5
Waittime=0
NodeName=$host NodeAddr=127.0.0.1 CPUs=4 State=UNKNOWN
PartitionName=gtest Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
slurmctld -i 2>"$D/log/slurmctld.err" || skip_all "slurmctld did not start"
slurmd 2>"$D/log/slurmd.err" || skip_all "slurmd did not start"
i=0
until sinfo -h -o '%T' 2>/dev/null | grep -q '^idle'; do
	i=$((i + 1)); [ $i -ge 150 ] && skip_all "the node did not become idle in 30 s ($(sinfo -h -o '%T' 2>&1 | head -n 1))"
	sleep 0.2
done
ok 0 "single-machine Slurm up: slurmctld on 127.0.0.1:$CTLD_PORT, slurmd on :$SLURMD_PORT, node $host idle"
srun --mpi=list 2>&1 | grep -q pmix
ok $? "srun offers the pmix plugin (Debian's Open MPI has no PMI-2 client: pmix is the one both speak)"

# sjob ID: the Slurm job id of the job's last attempt.
sjob() { field "$(api GET "/api/v1/jobs/$1")" 'd["attempts"][-1]["slurm_job"]'; }
# wait_file PATH [seconds]
wait_file() { i=0; until [ -s "$1" ] || [ $i -ge $(( ${2:-30} * 20 )) ]; do sleep 0.05; i=$((i + 1)); done; [ -s "$1" ]; }

SHORT='{"method":"ed","dimensions":2,"particles":{"count":400,"volume_fraction":0.2},"collisions":{"restitution":0.9},"run":{"seed":3,"until":{"time":0.2}},"output":{"every":{"time":0.02}}}'
LONG='{"method":"ed","dimensions":3,"particles":{"count":4000,"volume_fraction":0.3},"run":{"seed":1,"until":{"time":1e5}},"output":{"every":{"time":0.05}}}'
# A few seconds of work with checkpoints every 0.3 s of wall time.
CK='{"method":"ed","dimensions":2,"particles":{"count":20000,"volume_fraction":0.3},"run":{"seed":7,"until":{"time":100}},"output":{"every":{"time":10},"checkpoint":{"every":{"wall_seconds":0.3}}}}'
MID='{"method":"ed","dimensions":2,"particles":{"count":20000,"volume_fraction":0.3},"run":{"seed":7,"until":{"time":300}},"output":{"every":{"time":10},"checkpoint":{"every":{"wall_seconds":0.3}}}}'

S=$tmp/state
mkdir -p "$S"
gd_start "$S" --launcher slurm --slots 4 --slurm-poll 0.2
api GET /healthz >/dev/null
ok $([ "$(code)" = 200 ]; echo $?) "granulard with launcher = slurm answers on $URL"

# 1. submit -> sbatch -> completed -> succeeded, progress from the tailed file.
id=$(field "$(post /api/v1/jobs -d "$SHORT")" 'd["id"]')
wait_state "$id" succeeded 60
ok $? "job $id (1 rank) succeeded through Slurm"
job=$(api GET "/api/v1/jobs/$id")
sj=$(sjob "$id")
ok $([ "$sj" -gt 0 ] 2>/dev/null && [ "$(field "$job" 'd["attempts"][0]["slurm_state"]')" = completed ] &&
     [ "$(field "$job" 'd["attempts"][0]["exit_status"]')" = 0 ] && [ "$(field "$job" 'd["attempts"][0]["pid"]')" = None ]; echo $?) \
	"attempt 1: Slurm job $sj, state completed, exit 0, no local pid"
scontrol show job -o "$sj" | grep -q 'JobState=COMPLETED'
ok $? "Slurm itself says job $sj COMPLETED"
grep -q '^#SBATCH --ntasks=1$' "$S/jobs/$id/attempt-1.sbatch" && grep -q -- "--mpi=pmix" "$S/jobs/$id/attempt-1.sbatch"
ok $? "the batch script is in the job directory: --ntasks=1, srun --mpi=pmix"
prog=$(api GET "/api/v1/jobs/$id/progress")
ok $([ "$(field "$prog" 'len([r for r in d["records"] if r["type"]=="progress"])')" = 11 ] &&
     [ "$(field "$prog" 'd["records"][-1]["type"]')" = summary ]; echo $?) "stored series from attempt-1.out: 11 progress records and the summary"
fl=$(api GET "/api/v1/jobs/$id/files")
ok $([ "$(field "$fl" '"trajectory.h5" in [f["name"] for f in d["files"]] and "attempt-1.out" in [f["name"] for f in d["files"]]')" = True ]; echo $?) \
	"the files endpoint lists the engine's output and the attempt's Slurm output"

# Slurm options of a job: validated at submission, 400 naming the key.
for bad in '{"nodes":2}|slurm.nodes' '{"qos":"high"}|slurm.qos' '{"partition":"a b"}|slurm.partition' '{"time_limit":0}|slurm.time_limit'; do
	opt=${bad%|*} key=${bad#*|}
	r=$(post /api/v1/jobs -d "{\"scene\":$SHORT,\"slurm\":$opt}")
	ok $([ "$(code)" = 400 ] && [ "$(field "$r" 'd["error"]["message"].split(":")[0]')" = "$key" ]; echo $?) \
		"slurm $opt refused: 400 naming $key ($(field "$r" 'd["error"]["message"]'))"
done

# A partition the cluster does not have: sbatch refuses, the job fails with sbatch's message.
idn=$(field "$(post /api/v1/jobs -d "{\"scene\":$SHORT,\"slurm\":{\"partition\":\"nosuch\"}}")" 'd["id"]')
wait_state "$idn" failed 30
rn=$(field "$(api GET "/api/v1/jobs/$idn")" 'd["reason"]')
ok $(case $rn in sbatch*"invalid partition"*) true ;; *) false ;; esac; echo $?) "partition nosuch: job $idn failed: $rn"

# 2. a 2-rank job: one MPI world of 2 ranks (2 singletons would write every record twice).
id2=$(field "$(post /api/v1/jobs -d "{\"scene\":$SHORT,\"ranks\":2}")" 'd["id"]')
wait_state "$id2" succeeded 60
ok $? "job $id2 (2 ranks) succeeded"
sj2=$(sjob "$id2")
nt=$(scontrol show job -o "$sj2" | tr ' ' '\n' | sed -n 's/^NumTasks=//p')
nrec=$(grep -c '^{' "$S/jobs/$id2/attempt-1.out")
ok $([ "$nt" = 2 ] && [ "$nrec" = 12 ]; echo $?) "Slurm job $sj2 ran $nt tasks; its output has $nrec records (11 progress and the summary, once)"

# 3. pending: a blocker holds every CPU; the job waits in Slurm as pending, then runs.
blk=$(sbatch --parsable -n 4 -o /dev/null --wrap 'sleep 300')
i=0; until [ "$(squeue -h -j "$blk" -o %T)" = RUNNING ] || [ $i -ge 100 ]; do sleep 0.1; i=$((i + 1)); done
id3=$(field "$(post /api/v1/jobs -d "$SHORT")" 'd["id"]')
i=0; st=
while [ $i -lt 100 ]; do
	st=$(field "$(api GET "/api/v1/jobs/$id3")" 'd["attempts"][-1]["slurm_state"] if d["attempts"] else ""')
	case $st in "pending ("*) break ;; esac
	sleep 0.1; i=$((i + 1))
done
jst=$(field "$(api GET "/api/v1/jobs/$id3")" 'd["state"]')
ok $(case $st in "pending (Resources)"|"pending (Priority)") [ "$jst" = running ] ;; *) false ;; esac; echo $?) \
	"while a blocker holds the CPUs: job $id3 is $jst, its Slurm state '$st'"
"$GRANULARCTL" show "$id3" --url "$URL" >"$tmp/ctl" 2>&1
ok $(grep -Eq "^  attempt 1  slurm job $(sjob "$id3") pending \((Resources|Priority)\)$" "$tmp/ctl"; echo $?) \
	"granularctl show: the attempt's Slurm job and state: $(grep '^  attempt' "$tmp/ctl" | sed 's/^ *//')"
cl=$(api GET /api/v1/cluster)
ok $([ "$(field "$cl" 'd["launcher"]')" = slurm ] && [ "$(field "$cl" 'd["slurm"]["partition"]')" = gtest ] &&
     [ "$(field "$cl" 'd["slurm"]["nodes"]["total"]')" = 1 ] && [ "$(field "$cl" 'd["slurm"]["nodes"]["allocated"]')" = 1 ] &&
     [ "$(field "$cl" 'd["slurm"]["cpus"]["allocated"]')" = 4 ] && [ "$(field "$cl" 'd["slurm"]["cpus"]["idle"]')" = 0 ] &&
     [ "$(field "$cl" 'd["slurm"]["pending_jobs"]')" = 1 ]; echo $?) \
	"GET /cluster: partition gtest, 1 node allocated, 4/4 CPUs allocated, 1 pending job ($(field "$cl" 'd["slurm"]'))"
"$GRANULARCTL" cluster --url "$URL" >"$tmp/ctl" 2>&1
ok $(grep -q '^  slurm      partition gtest: 1 nodes (0 idle), CPUs 4 allocated of 4 (0 idle), 1 pending jobs$' "$tmp/ctl"; echo $?) \
	"granularctl cluster shows the partition: $(grep slurm "$tmp/ctl" | sed 's/^ *//')"
scancel "$blk"
wait_state "$id3" succeeded 60
ok $? "the blocker cancelled: job $id3 ran and succeeded"
sleep 1.1   # past the /cluster cache
cl=$(api GET /api/v1/cluster)
ok $([ "$(field "$cl" 'd["slurm"]["cpus"]["idle"]')" = 4 ] && [ "$(field "$cl" 'd["slurm"]["pending_jobs"]')" = 0 ]; echo $?) \
	"GET /cluster afterwards: 4 idle CPUs, no pending job"

# 4. live progress and cancel: records arrive while the Slurm job runs; cancel -> scancel.
id4=$(field "$(post /api/v1/jobs -d "$LONG")" 'd["id"]')
curl -sN -m 30 "$URL/api/v1/jobs/$id4/events" >"$tmp/sse4" &
sse=$!
i=0; until grep -q '^event: progress' "$tmp/sse4" || [ $i -ge 300 ]; do sleep 0.1; i=$((i + 1)); done
j4=$(api GET "/api/v1/jobs/$id4")
ok $(grep -q '^event: progress' "$tmp/sse4" && [ "$(field "$j4" 'd["state"]')" = running ] &&
     [ "$(field "$j4" 'd["progress_records"]["stored"] > 0')" = True ]; echo $?) \
	"live: progress events on the stream and $(field "$j4" 'd["progress_records"]["stored"]') records stored while Slurm job $(sjob "$id4") runs"
sj4=$(sjob "$id4")
post "/api/v1/jobs/$id4/cancel" >/dev/null
wait_state "$id4" cancelled 30
ok $? "POST /cancel: job $id4 cancelled"
j4=$(api GET "/api/v1/jobs/$id4")
ok $([ -z "$(squeue -h -j "$sj4" -o %i 2>/dev/null)" ] && scontrol show job -o "$sj4" | grep -q 'JobState=CANCELLED' &&
     [ "$(field "$j4" 'd["attempts"][-1]["slurm_state"]')" = cancelled ] && [ "$(field "$j4" 'len(d["attempts"])')" = 1 ]; echo $?) \
	"Slurm job $sj4 is CANCELLED and gone from the queue; one attempt"
kill "$sse" 2>/dev/null; wait "$sse" 2>/dev/null

# 5. Slurm's time limit (a minute at least; Slurm looks every 30 s or so): the job's own "slurm" options make
# the sbatch options, and a job killed at its limit is retried from its checkpoint. It runs beside steps 5 and 6.
TL='{"method":"ed","dimensions":2,"particles":{"count":2000,"volume_fraction":0.3},"run":{"seed":5,"until":{"time":1e7}},"output":{"every":{"time":50},"checkpoint":{"every":{"wall_seconds":5}}}}'
# Submitted with granularctl's flags: they reach sbatch through the submission's "slurm" object.
echo "$TL" >"$tmp/tl.json"
idt=$(field "$("$GRANULARCTL" submit "$tmp/tl.json" --url "$URL" --token-file "$S/token" --time-limit 60 --nodes 1 --partition gtest --account gacct --json)" 'd["id"]')
wait_file "$S/jobs/$idt/attempt-1.sbatch" 30
ok $(grep -q '^#SBATCH --time=1$' "$S/jobs/$idt/attempt-1.sbatch" && grep -q '^#SBATCH --nodes=1$' "$S/jobs/$idt/attempt-1.sbatch" &&
     grep -q '^#SBATCH --partition=gtest$' "$S/jobs/$idt/attempt-1.sbatch" &&
     grep -q '^#SBATCH --account=gacct$' "$S/jobs/$idt/attempt-1.sbatch" &&
     [ "$(field "$(api GET "/api/v1/jobs/$idt")" 'd["slurm"]["time_limit"]')" = 60 ]; echo $?) \
	"job $idt's slurm options: --time=1 (minutes), --nodes=1, --partition=gtest, --account=gacct in its batch script, and on the job"

# 6. scancel --signal=KILL from outside: retried from the checkpoint like a local crash, and the result is
# the uninterrupted run's (the engine's resume is exact: docs/output.md, "Checkpoints").
mkdir -p "$tmp/ref" && echo "$CK" >"$tmp/ck.json"
"$ENGINE" run "$tmp/ck.json" --out "$tmp/ref" >"$tmp/ref.out" 2>"$tmp/ref.err"
ref=$(tail -n 1 "$tmp/ref.out")
id5=$(field "$(post /api/v1/jobs -d "$CK")" 'd["id"]')
wait_file "$S/jobs/$id5/checkpoint.h5" 60
sj5=$(sjob "$id5")
scancel --signal=KILL "$sj5"
wait_state "$id5" succeeded 90
ok $? "job $id5: Slurm job $sj5 killed with scancel --signal=KILL after a checkpoint, then succeeded"
j5=$(api GET "/api/v1/jobs/$id5")
ok $([ "$(field "$j5" 'len(d["attempts"])')" = 2 ] && [ "$(field "$j5" 'd["attempts"][1]["checkpoint"]')" = checkpoint.h5 ] &&
     [ "$(field "$j5" 'd["attempts"][0]["slurm_state"]')" = cancelled ] &&
     [ "$(field "$j5" 'd["attempts"][1]["slurm_job"] != d["attempts"][0]["slurm_job"]')" = True ]; echo $?) \
	"attempt 2 is a new Slurm job resumed from checkpoint.h5 ($(field "$j5" 'd["attempts"][0]["reason"]'))"
got=$(field "$(api GET "/api/v1/jobs/$id5/progress")" 'json.dumps([d["records"][-1][k] for k in ("events","collisions","kinetic_energy")])')
want=$(field "$ref" 'json.dumps([d[k] for k in ("events","collisions","kinetic_energy")])')
ok $([ -n "$want" ] && [ "$got" = "$want" ]; echo $?) "killed and resumed: events, collisions, kinetic energy equal the uninterrupted run's ($got)"

# 7. daemon kill -9 and restart while a Slurm job runs: the job runs on in Slurm, the new daemon follows it
# again; one attempt (none run twice) and a progress series without a gap or a repeat.
id6=$(field "$(post /api/v1/jobs -d "$MID")" 'd["id"]')
wait_file "$S/jobs/$id6/attempt-1.out" 60
sleep 1
sj6=$(sjob "$id6")
sjt=$(sjob "$idt")
kill -9 "$GD_PID"; wait "$GD_PID" 2>/dev/null; GD_PID=
ok $([ "$(squeue -h -j "$sj6" -o %T)" = RUNNING ]; echo $?) "granulard killed -9: Slurm job $sj6 still RUNNING"
# As if the daemon had died between sbatch's answer and the database: the time-limited job's Slurm id is
# erased; the next daemon must find its Slurm job by name (squeue), not submit it again.
/usr/bin/python3 -c 'import sqlite3,sys; c=sqlite3.connect(sys.argv[1]); c.execute("UPDATE attempts SET slurm_job=NULL, slurm_state=NULL WHERE job_id=? AND n=1", (int(sys.argv[2]),)); c.commit()' "$S/granulard.db" "$idt"
sleep 1
gd_start "$S" --launcher slurm --slots 4 --slurm-poll 0.2
wait_state "$id6" succeeded 90
ok $? "restarted granulard followed job $id6 to its end: succeeded"
j6=$(api GET "/api/v1/jobs/$id6")
times=$(field "$(api GET "/api/v1/jobs/$id6/progress?limit=1000")" '" ".join(str(r["time"]) for r in d["records"] if r["type"]=="progress")')
ok $([ "$(field "$j6" 'len(d["attempts"])')" = 1 ] && [ "$(field "$j6" 'd["attempts"][0]["slurm_job"]')" = "$sj6" ] &&
     [ "$times" = "$(seq -s ' ' 0 10 300)" ]; echo $?) \
	"one attempt (Slurm job $sj6), progress t = 0, 10, ..., 300 each once across the restart"
grep -q "job $id6: following Slurm job $sj6 again" "$S.log"
ok $? "the restarted daemon logged that it follows Slurm job $sj6 again"
jt=$(api GET "/api/v1/jobs/$idt")
ok $([ "$(field "$jt" 'd["attempts"][0]["slurm_job"]')" = "$sjt" ] && grep -q "job $idt: following Slurm job $sjt again" "$S.log"; echo $?) \
	"job $idt, whose Slurm id was not stored: found by its job name, Slurm job $sjt followed again (not submitted twice)"

# 5, the end: attempt 1 ended at its time limit, attempt 2 resumed from the checkpoint.
i=0
while [ $i -lt 1500 ]; do
	jt=$(api GET "/api/v1/jobs/$idt")
	[ "$(field "$jt" 'len(d["attempts"]) >= 2 and d["attempts"][1]["slurm_job"] is not None')" = True ] && break
	sleep 0.1; i=$((i + 1))
done
ok $([ "$(field "$jt" 'd["attempts"][0]["slurm_state"]')" = "timeout (TimeLimit)" ] && [ "$(field "$jt" 'd["attempts"][1]["checkpoint"]')" = checkpoint.h5 ] &&
     [ "$(field "$jt" 'd["state"]')" = running ]; echo $?) \
	"job $idt: Slurm's time limit ended attempt 1 ($(field "$jt" 'd["attempts"][0]["reason"]')); attempt 2 resumes from checkpoint.h5"
post "/api/v1/jobs/$idt/cancel" >/dev/null
wait_state "$idt" cancelled 30
ok $? "job $idt cancelled"

# 8. The same state directory under launcher = mpirun: a Slurm job left by the Slurm daemon is cancelled in
# Slurm before the job runs here (never two copies).
id8=$(field "$(post /api/v1/jobs -d "$LONG")" 'd["id"]')
wait_file "$S/jobs/$id8/attempt-1.out" 60
sj8=$(sjob "$id8")
kill -9 "$GD_PID"; wait "$GD_PID" 2>/dev/null; GD_PID=
gd_start "$S" --slots 4
i=0; until [ "$(field "$(api GET "/api/v1/jobs/$id8")" 'd["attempts"][-1]["pid"] is not None')" = True ] || [ $i -ge 300 ]; do sleep 0.1; i=$((i + 1)); done
j8=$(api GET "/api/v1/jobs/$id8")
ok $(scontrol show job -o "$sj8" | grep -Eq 'JobState=(CANCELLED|COMPLETING)' && [ "$(field "$j8" 'len(d["attempts"])')" = 2 ] &&
     [ "$(field "$j8" 'd["attempts"][1]["slurm_job"]')" = None ]; echo $?) \
	"restarted with launcher = mpirun: Slurm job $sj8 cancelled, attempt 2 runs locally (pid $(field "$j8" 'd["attempts"][-1]["pid"]'))"
post "/api/v1/jobs/$id8/cancel" >/dev/null
wait_state "$id8" cancelled 30

gd_stop
finish
