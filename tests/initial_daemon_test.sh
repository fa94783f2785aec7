#!/bin/sh
# A job continued from another job's last frame through the daemon ("from": {"job": ID}), and the paths it refuses (TAP).
set -u
. "$(dirname "$0")/daemon_lib.sh"

A='{"method":"ed","dimensions":2,"particles":{"count":200,"box":[25,25],"initial":{"positions":"random"}},"collisions":{"restitution":0.9,"tc":1e-6},"run":{"seed":4,"until":{"time":2}},"output":{"every":{"time":1},"snapshots":{"every":{"time":1}}}}'
# from_job ID [FRAME]: the scene continued from job ID's frame.
from() { echo '{"method":"ed","dimensions":2,"particles":{"count":200,"box":[25,25],"initial":{"from":'"$1"'}},"collisions":{"restitution":0.9,"tc":1e-6},"run":{"seed":4,"until":{"time":1}},"output":{"every":{"time":1}}}'; }
LONG='{"method":"ed","dimensions":2,"particles":{"count":200,"volume_fraction":0.2},"run":{"seed":1,"until":{"time":1e6}},"output":{"every":{"time":1}}}'

# err_key CODE KEY DESCRIPTION: the status, and a JSON error body whose message starts with "KEY: ".
err_key() {
	msg=$(field "$(cat "$tmp/body")" 'd["error"]["message"]')
	case "$msg" in "$2: "*) k=0 ;; *) k=1 ;; esac
	ok $([ "$(code)" = "$1" ] && [ -n "$(field "$(cat "$tmp/body")" 'd["error"]["code"]')" ] && [ $k = 0 ]; echo $?) \
		"$3: $CODE $msg"
}
# same_frame FILE_A K FILE_B: frame K of A equals frame 0 of B, positions and velocities, bit for bit.
same_frame() {
	for what in position velocity; do
		h5dump -d "/particles/all/$what/value" -s "$2,0,0" -c "1,200,2" -b LE -o "$tmp/fa" "$1" >/dev/null 2>&1 &&
		h5dump -d "/particles/all/$what/value" -s "0,0,0" -c "1,200,2" -b LE -o "$tmp/fb" "$3" >/dev/null 2>&1 &&
		[ -s "$tmp/fa" ] && cmp -s "$tmp/fa" "$tmp/fb" || return 1
	done
}

S=$tmp/state
gd_start "$S" --slots 2
a=$(field "$(post /api/v1/jobs -d "$A")" 'd["id"]')
wait_state "$a" succeeded 60
ok $? "job A ($a) succeeds with frames at t = 0, 1, 2"

b=$(field "$(post /api/v1/jobs -d "$(from '{"job":'"$a"'}')")" 'd["id"]')
ok $([ "$(code)" = 201 ]; echo $?) "a job from {\"job\": $a} is accepted ($(code))"
wait_state "$b" succeeded 60
ok $? "... and succeeds ($(field "$(api GET "/api/v1/jobs/$b")" 'd.get("reason") or "no reason"'))"
same_frame "$S/jobs/$a/trajectory.h5" 2 "$S/jobs/$b/trajectory.h5"
ok $? "job $b starts in job $a's last frame bit for bit"

c=$(field "$(post /api/v1/jobs -d "$(from '{"job":'"$a"',"frame":1}')")" 'd["id"]')
wait_state "$c" succeeded 60 && same_frame "$S/jobs/$a/trajectory.h5" 1 "$S/jobs/$c/trajectory.h5"
ok $? "frame 1 of job $a: job $c starts in it bit for bit"

# A relative file is taken from the job's own directory: another job's trajectory is ../ID/trajectory.h5.
d=$(field "$(post /api/v1/jobs -d "$(from '{"file":"../'"$a"'/trajectory.h5"}')")" 'd["id"]')
wait_state "$d" succeeded 60 && same_frame "$S/jobs/$a/trajectory.h5" 2 "$S/jobs/$d/trajectory.h5"
ok $? "from {\"file\": \"../$a/trajectory.h5\"}: job $d starts in job $a's last frame"

# Refused at submission with 400 naming the key.
post /api/v1/jobs -d "$(from '{"job":999999}')" >/dev/null
err_key 400 particles.initial.from.job "a job that does not exist"
l=$(field "$(post /api/v1/jobs -d "$LONG")" 'd["id"]')
wait_state "$l" running 30
post /api/v1/jobs -d "$(from '{"job":'"$l"'}')" >/dev/null
err_key 400 particles.initial.from.job "a job still running (its trajectory is not complete)"
post "/api/v1/jobs/$l/cancel" >/dev/null
for fp in /etc/passwd ../../granulard.db ../../../etc/passwd "../$a/../../token" "x/../../../y.h5"; do
	post /api/v1/jobs -d "$(from '{"file":"'"$fp"'"}')" >/dev/null
	err_key 400 particles.initial.from.file "file \"$fp\" leaves the job directories"
done
post /api/v1/scenes/validate -d "$(from '{"file":"/etc/passwd"}')" >/dev/null
err_key 400 particles.initial.from.file "validate refuses it too"
ok $([ ! -e "$S/jobs/$((l + 1))" ]; echo $?) "no job was created by the refused submissions"

# A frame the engine refuses (out of range) fails the job with the engine's line, not retried.
e=$(field "$(post /api/v1/jobs -d "$(from '{"job":'"$a"',"frame":7}')")" 'd["id"]')
wait_state "$e" failed 60
ok $? "frame 7 of a 3-frame trajectory: the job fails"
msg=$(field "$(api GET "/api/v1/jobs/$e")" 'd.get("reason") or ""')
case "$msg" in *particles.initial.from.frame*) k=0 ;; *) k=1 ;; esac
ok $k "... naming the key: $msg"

gd_stop
finish
