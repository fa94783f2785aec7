#!/bin/sh
# Checkpoints of one dsmc/hsmc system split over MPI ranks (engine/par/dsmcrun.h) through the real program (TAP):
# checkpointed at P ranks, resumed at P' = 1 (plain, no --split), 2 and 3, equal to the uninterrupted run; SIGTERM
# writes a checkpoint and exits 4; a damaged checkpoint falls back to the previous one; particles.initial.from.
set -u
: "${SRCDIR:=$(cd "$(dirname "$0")/.." && pwd)}"
: "${ENGINE:=$SRCDIR/engine/granular-engine}"
PY=/usr/bin/python3
tmp=$(mktemp -d "${TMPDIR:-/tmp}/dsmc_split_resume_test.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
n=0; failed=0
. "$SRCDIR/tests/tap_lib.sh"   # ok(), report()
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1

if ! command -v mpirun >/dev/null 2>&1; then
	echo "1..0 # SKIP no mpirun"
	exit 0
fi
if ! "$PY" -c 'import h5py, numpy' 2>/dev/null; then
	echo "1..0 # SKIP python3-h5py not installed"
	exit 0
fi

# launch NP ARGS...: the engine on NP ranks (1: a plain run, no mpirun, no --split)
launch() {
	np=$1; shift
	if [ "$np" = 1 ]; then "$ENGINE" "$@"; else mpirun --oversubscribe -np "$np" "$ENGINE" "$@"; fi
}
# The exact columns of progress.jsonl (docs/parallel.md): pressure, compressibility and momentum are sums of
# doubles over ranks and are compared by same_h5 to 1e-12 relative (1e-9 absolute for the momentum, exactly 0
# up to rounding ~1e-12); wall-clock figures and memory (per rank count) are left out.
strip() { sed 's/"wall_seconds":[^,}]*//; s/"events_per_second":[^,}]*//; s/"collisions_per_second":[^,}]*//;
               s/"memory_bytes":[^,}]*//; s/"pressure":[^,}]*//; s/"compressibility":[^,}]*//;
               s/"momentum":\[[^]]*\]//' "$1"; }
# same_h5 A B [noscene]: every dataset of trajectory.h5 equal byte for byte, but pressure, compressibility and
# momentum (bounds above) and, with noscene, the stored scene text; prints the frame times.
same_h5() {
	"$PY" - "$1" "$2" "${3:-}" <<'PY'
import sys, h5py, numpy as np
def walk(g, out, p=""):
    for k in g:
        o = g[k]
        if isinstance(o, h5py.Dataset):
            out[p + "/" + k] = o[()]
        else:
            walk(o, out, p + "/" + k)
a, b = {}, {}
walk(h5py.File(sys.argv[1], "r"), a)
walk(h5py.File(sys.argv[2], "r"), b)
assert sorted(a) == sorted(b), (sorted(a), sorted(b))
for k in a:
    if k == "/parameters/scene" and sys.argv[3] == "noscene":
        continue
    if "pressure" in k or "compressibility" in k:
        assert np.allclose(a[k], b[k], rtol=1e-12, atol=0, equal_nan=True), k
    elif "momentum/value" in k:
        assert np.allclose(a[k], b[k], rtol=0, atol=1e-9), k
    else:
        assert np.asarray(a[k]).tobytes() == np.asarray(b[k]).tobytes(), k
print("frames at %s" % np.round(a["/particles/all/position/time"], 4).tolist())
PY
}
# same_progress A B: the exact columns byte for byte, the others to the bounds above
same_progress() {
	strip "$1" >"$tmp/sa"; strip "$2" >"$tmp/sb"
	cmp -s "$tmp/sa" "$tmp/sb" || return 1
	"$PY" - "$1" "$2" <<'PY'
import json, sys
a = [json.loads(l) for l in open(sys.argv[1]) if l.startswith("{")]
b = [json.loads(l) for l in open(sys.argv[2]) if l.startswith("{")]
assert len(a) == len(b) and len(a) > 2
for x, y in zip(a, b):
    for k in ("pressure", "compressibility"):
        if x.get(k) is not None:
            assert abs(x[k] - y[k]) <= 1e-12 * abs(x[k]), (k, x[k], y[k])
    for u, v in zip(x.get("momentum", []), y.get("momentum", [])):
        assert abs(u - v) <= 1e-9, ("momentum", u, v)
PY
}

# 1. Checkpoints by simulated time: a cooling 3D gas (N = 5000, nu = 0.2, 7^3 cells, ~60 steps), checkpoints
#    every 0.6 (at the end of the steps reaching 0.6, 1.2 and 1.8, not cut: checkpoint.prev.h5 just after 1.2),
#    frames every 0.7, written by 2 ranks. Resumed from checkpoint.prev.h5 at 1 (a plain run:
#    the file says it is a split run's), 2 and 3 ranks: progress.jsonl and trajectory.h5 equal the
#    uninterrupted run's (which is itself checked against 1 and 3 ranks: checkpoints do not change the run).
cat >"$tmp/p.json" <<'EOF'
{"method":"dsmc","dimensions":3,"particles":{"count":5000,"volume_fraction":0.2,"initial":{"positions":"random"}},
 "collisions":{"restitution":0.9},"run":{"seed":5,"until":{"time":2}},
 "output":{"every":{"time":0.25},"snapshots":{"every":{"time":0.7}},"checkpoint":{"every":{"time":0.6}},
           "observables":["kinetic_energy","temperature","pressure","compressibility","collision_rate","momentum"]}}
EOF
launch 2 run "$tmp/p.json" --out "$tmp/A" >/dev/null 2>"$tmp/A.err"
rc=$?
tprev=$("$PY" -c 'import h5py, sys; print(h5py.File(sys.argv[1], "r").attrs["time"])' "$tmp/A/checkpoint.prev.h5" 2>/dev/null)
tcur=$("$PY" -c 'import h5py, sys; print(h5py.File(sys.argv[1], "r").attrs["time"])' "$tmp/A/checkpoint.h5" 2>/dev/null)
ok $(( rc == 0 && ${#tprev} > 0 ? 0 : 1 )) "2 ranks with output.checkpoint: exit $rc, checkpoints at t = ${tprev:-none} and ${tcur:-none} $(head -c 200 "$tmp/A.err")"
for np in 1 3; do
	sed 's/"checkpoint":{"every":{"time":0.6}},//' "$tmp/p.json" >"$tmp/q.json"
	launch $np run "$tmp/q.json" --split --out "$tmp/Q$np" >/dev/null 2>&1
	rc=$?
	same_progress "$tmp/A/progress.jsonl" "$tmp/Q$np/progress.jsonl" && same_h5 "$tmp/A/trajectory.h5" "$tmp/Q$np/trajectory.h5" noscene >/dev/null
	ok $(( rc == 0 && $? == 0 ? 0 : 1 )) "the run without checkpoints on $np rank(s) equals it (exit $rc)"
done
for np in 1 2 3; do
	rm -rf "$tmp/B$np"
	cp -r "$tmp/A" "$tmp/B$np"
	cp "$tmp/A/checkpoint.prev.h5" "$tmp/B$np/checkpoint.h5"
	launch $np run "$tmp/p.json" --out "$tmp/B$np" --resume "$tmp/B$np/checkpoint.h5" >"$tmp/B$np.out" 2>"$tmp/B$np.err"
	rc=$?
	first=$(head -n 1 "$tmp/B$np.out" | sed -n 's/.*"time":\([0-9.]*\).*/\1/p')
	same_progress "$tmp/A/progress.jsonl" "$tmp/B$np/progress.jsonl" &&
		same_h5 "$tmp/A/trajectory.h5" "$tmp/B$np/trajectory.h5" >"$tmp/f.res"
	ok $(( rc == 0 && $? == 0 ? 0 : 1 )) "checkpointed at 2 ranks (t = $tprev), resumed at $np: progress.jsonl and trajectory.h5 equal the uninterrupted run's ($(cat "$tmp/f.res"); first record on stdout at t = $first; exit $rc $(head -c 200 "$tmp/B$np.err"))"
done

# 2. hsmc, dense 2D with CBA (records displaced out of the cells they were sorted into, which the next step's
#    cell-cell pass uses): checkpointed at 3 ranks, resumed at 1 and 2.
cat >"$tmp/h.json" <<'EOF'
{"method":"hsmc","dimensions":2,"particles":{"count":6000,"volume_fraction":0.75,"initial":{"positions":"random"}},
 "collisions":{"restitution":0.9},"hsmc":{"cell_size":2,"correction":"cba"},"run":{"seed":4,"until":{"time":0.5}},
 "output":{"every":{"time":0.1},"checkpoint":{"every":{"time":0.2}}}}
EOF
launch 3 run "$tmp/h.json" --out "$tmp/H" >/dev/null 2>"$tmp/H.err"
rc0=$?
for np in 1 2; do
	rm -rf "$tmp/H$np"
	cp -r "$tmp/H" "$tmp/H$np"
	cp "$tmp/H/checkpoint.prev.h5" "$tmp/H$np/checkpoint.h5"
	launch $np run "$tmp/h.json" --out "$tmp/H$np" --resume "$tmp/H$np/checkpoint.h5" >/dev/null 2>"$tmp/H$np.err"
	rc=$?
	same_progress "$tmp/H/progress.jsonl" "$tmp/H$np/progress.jsonl" &&
		same_h5 "$tmp/H/trajectory.h5" "$tmp/H$np/trajectory.h5" >/dev/null
	same=$?
	cc=$(tail -n 1 "$tmp/H$np/progress.jsonl" | sed -n 's/.*"cell_collisions":\([0-9]*\).*/\1/p')
	ok $(( rc0 == 0 && rc == 0 && same == 0 && ${cc:-0} > 0 ? 0 : 1 )) "hsmc/cba checkpointed at 3 ranks, resumed at $np: equal to the uninterrupted run ($cc cell collisions; exit $rc0, $rc $(head -c 200 "$tmp/H$np.err"))"
done

# 2b. A schedule in collisions per particle (run.until, output.every, output.snapshots), 2D with CBA, checkpoints
#     in time: checkpointed at 2 ranks, resumed at 3 from checkpoint.prev.h5, the same records and frames.
cat >"$tmp/c.json" <<'EOF'
{"method":"dsmc","dimensions":2,"particles":{"count":4000,"volume_fraction":0.1,"initial":{"positions":"random"}},
 "collisions":{"restitution":0.8},"dsmc":{"correction":"cba"},"run":{"seed":8,"until":{"collisions_per_particle":3}},
 "output":{"every":{"collisions_per_particle":0.5},"snapshots":{"every":{"collisions_per_particle":1}},
           "checkpoint":{"every":{"time":2}},"observables":["kinetic_energy","collision_rate","pressure"]}}
EOF
launch 2 run "$tmp/c.json" --out "$tmp/C" >/dev/null 2>"$tmp/C.err"
rc0=$?
rm -rf "$tmp/C3"
cp -r "$tmp/C" "$tmp/C3"
cp "$tmp/C/checkpoint.prev.h5" "$tmp/C3/checkpoint.h5"
tc=$("$PY" -c 'import h5py, sys; print(h5py.File(sys.argv[1], "r").attrs["time"])' "$tmp/C3/checkpoint.h5" 2>/dev/null)
launch 3 run "$tmp/c.json" --out "$tmp/C3" --resume "$tmp/C3/checkpoint.h5" >/dev/null 2>"$tmp/C3.err"
rc=$?
same_progress "$tmp/C/progress.jsonl" "$tmp/C3/progress.jsonl" && same_h5 "$tmp/C/trajectory.h5" "$tmp/C3/trajectory.h5" >"$tmp/f.res"
ok $(( rc0 == 0 && rc == 0 && $? == 0 && ${#tc} > 0 ? 0 : 1 )) "collisions-per-particle schedule, checkpointed at 2 ranks (t = ${tc:-none}), resumed at 3: equal ($(cat "$tmp/f.res"); exit $rc0, $rc $(head -c 200 "$tmp/C3.err"))"

# 3. SIGTERM to the ranks (as granulard sends it) of a 2-rank run with --out: a checkpoint between two steps
#    (rank 0's flag, reduced with the step's sums), a summary with status interrupted, exit 4 (through mpirun); resumed
#    at 3 ranks it ends with the records of the uninterrupted run. Elastic 3D gas, N = 20000, ~700 steps.
cat >"$tmp/long.json" <<'EOF'
{"method":"dsmc","dimensions":3,"particles":{"count":20000,"volume_fraction":0.1,"initial":{"positions":"random"}},
 "collisions":{"restitution":1},"run":{"seed":2,"until":{"time":80}},
 "output":{"every":{"time":4},"observables":["kinetic_energy","temperature","pressure","momentum"]}}
EOF
launch 1 run "$tmp/long.json" --split --out "$tmp/L" >/dev/null 2>&1
mpirun -np 2 "$ENGINE" run "$tmp/long.json" --out "$tmp/K" >"$tmp/K.out" 2>/dev/null &
pid=$!
i=0; until [ -s "$tmp/K.out" ] || [ $i -ge 300 ]; do sleep 0.1; i=$((i + 1)); done
sleep 0.5
kill -TERM $(pgrep -P $pid) 2>/dev/null
wait $pid
rc=$?
tail -n 1 "$tmp/K.out" | grep -q '"type":"summary","status":"interrupted"'
st=$?
tk=$("$PY" -c 'import h5py, sys; print(h5py.File(sys.argv[1], "r").attrs["time"])' "$tmp/K/checkpoint.h5" 2>/dev/null)
ok $(( rc == 4 && st == 0 && ${#tk} > 0 ? 0 : 1 )) "SIGTERM to the ranks: exit $rc, summary interrupted, checkpoint at t = ${tk:-none}"
launch 3 run "$tmp/long.json" --out "$tmp/K" --resume "$tmp/K/checkpoint.h5" >/dev/null 2>"$tmp/K2.err"
rc=$?
same_progress "$tmp/L/progress.jsonl" "$tmp/K/progress.jsonl"
ok $(( rc == 0 && $? == 0 ? 0 : 1 )) "... resumed at 3 ranks: progress.jsonl equal to the uninterrupted 1-rank run's ($(wc -l <"$tmp/K/progress.jsonl") lines, exit $rc $(head -c 200 "$tmp/K2.err"))"

# 3b. Wall-clock checkpoints (output.checkpoint.every.wall_seconds 0.2, rank 0's clock, looked at each step): the
#     2-rank run writes them and its records equal the run without; resumed at 1 rank from the last one (a plain
#     run), it ends with the same records.
sed 's/"output":{/"output":{"checkpoint":{"every":{"wall_seconds":0.2}},/' "$tmp/long.json" >"$tmp/wall.json"
launch 2 run "$tmp/wall.json" --out "$tmp/W" >/dev/null 2>"$tmp/W.err"
rc=$?
tw=$("$PY" -c 'import h5py, sys; print(h5py.File(sys.argv[1], "r").attrs["time"])' "$tmp/W/checkpoint.h5" 2>/dev/null)
same_progress "$tmp/L/progress.jsonl" "$tmp/W/progress.jsonl"
ok $(( rc == 0 && $? == 0 && ${#tw} > 0 ? 0 : 1 )) "wall-clock checkpoints at 2 ranks: records equal the run without, the last at t = ${tw:-none} (exit $rc $(head -c 200 "$tmp/W.err"))"
launch 1 run "$tmp/wall.json" --out "$tmp/W" --resume "$tmp/W/checkpoint.h5" >/dev/null 2>"$tmp/W1.err"
rc=$?
same_progress "$tmp/L/progress.jsonl" "$tmp/W/progress.jsonl"
ok $(( rc == 0 && $? == 0 ? 0 : 1 )) "... resumed from it on 1 rank: the same records (exit $rc $(head -c 200 "$tmp/W1.err"))"

# 4. A damaged checkpoint.h5 (one byte changed: the file digest) falls back to checkpoint.prev.h5, with the line
#    the daemon reads ("; using ..."), and the run still ends as the uninterrupted one.
rm -rf "$tmp/D"
cp -r "$tmp/A" "$tmp/D"
"$PY" - "$tmp/D/checkpoint.h5" <<'PY'
import sys
with open(sys.argv[1], "r+b") as f:
    f.seek(4096)
    b = f.read(1)
    f.seek(4096)
    f.write(bytes([b[0] ^ 0x55]))
PY
launch 2 run "$tmp/p.json" --out "$tmp/D" --resume "$tmp/D/checkpoint.h5" >/dev/null 2>"$tmp/D.err"
rc=$?
grep -q "; using $tmp/D/checkpoint.prev.h5" "$tmp/D.err" && same_progress "$tmp/A/progress.jsonl" "$tmp/D/progress.jsonl"
ok $(( rc == 0 && $? == 0 ? 0 : 1 )) "damaged checkpoint: falls back to checkpoint.prev.h5 and ends as the uninterrupted run (exit $rc: $(head -c 200 "$tmp/D.err"))"
# another scene's checkpoint: exit 2, one line, no fallback
sed 's/"seed":5/"seed":6/' "$tmp/p.json" >"$tmp/p6.json"
launch 1 run "$tmp/p6.json" --out "$tmp/B1" --resume "$tmp/B1/checkpoint.h5" >/dev/null 2>"$tmp/S.err"
rc=$?
ok $(( rc == 2 && $(wc -l <"$tmp/S.err") == 1 ? 0 : 1 )) "another scene's split checkpoint: exit $rc, $(head -c 200 "$tmp/S.err")"

# 5. particles.initial.from on the split path: frame 1 of run A (t = 0.73) continued on 1 (--split), 2 and 3
#    ranks: the records are equal, and the first frame of each is the source frame, byte for byte.
cat >"$tmp/from.json" <<EOF
{"method":"dsmc","dimensions":3,"particles":{"count":5000,"volume_fraction":0.2,"initial":{"from":{"file":"$tmp/A/trajectory.h5","frame":1}}},
 "collisions":{"restitution":0.9},"run":{"seed":9,"until":{"time":0.5}},
 "output":{"every":{"time":0.1},"observables":["kinetic_energy","temperature","pressure","momentum"]}}
EOF
for np in 1 2 3; do
	if [ $np = 1 ]; then "$ENGINE" run "$tmp/from.json" --split --out "$tmp/F$np" >/dev/null 2>"$tmp/F$np.err"
	else launch $np run "$tmp/from.json" --out "$tmp/F$np" >/dev/null 2>"$tmp/F$np.err"; fi
	rc=$?
	"$PY" - "$tmp/A/trajectory.h5" "$tmp/F$np/trajectory.h5" <<'PY'
import sys, h5py
a, b = h5py.File(sys.argv[1], "r"), h5py.File(sys.argv[2], "r")
for q in ("position", "velocity"):
    assert a["particles/all/%s/value" % q][1].tobytes() == b["particles/all/%s/value" % q][0].tobytes(), q
assert b["particles/all/position/time"][-1] == 0.5
PY
	fr=$?
	if [ $np = 1 ]; then cp "$tmp/F1/progress.jsonl" "$tmp/F.ref"; fi
	same_progress "$tmp/F.ref" "$tmp/F$np/progress.jsonl"
	ok $(( rc == 0 && fr == 0 && $? == 0 ? 0 : 1 )) "initial.from on $np rank(s): first frame = the source frame, records equal to 1 rank's (exit $rc $(head -c 200 "$tmp/F$np.err"))"
done

echo "1..$n"
[ "$failed" = 0 ]
