#!/bin/sh
# schema/openapi.yaml and the daemon's route table agree, and every documented route answers on a live daemon.
set -u
. "$(dirname "$0")/daemon_lib.sh"
PY=/usr/bin/python3
"$GRANULARD" --list-routes | sort >"$tmp/routes"
"$PY" - "$SRCDIR/schema/openapi.yaml" >"$tmp/spec" <<'PYEOF'
import sys, yaml
spec = yaml.safe_load(open(sys.argv[1]))
for path, ops in spec["paths"].items():
    for m in ops:
        if m in ("get", "post", "put", "delete", "patch"):
            print(m.upper(), path)
PYEOF
sort -o "$tmp/spec" "$tmp/spec"
# DELETE last: it removes the job the other operations use.
{ grep -v '^DELETE' "$tmp/spec"; grep '^DELETE' "$tmp/spec"; } >"$tmp/order"
ok $([ -s "$tmp/spec" ]; echo $?) "openapi.yaml parses and lists $(wc -l <"$tmp/spec") operations"
missing=$(comm -23 "$tmp/routes" "$tmp/spec" | tr '\n' ';')
ok $([ -z "$missing" ]; echo $?) "every route of the daemon is documented ${missing:+(missing: $missing)}"
extra=$(comm -13 "$tmp/routes" "$tmp/spec" | tr '\n' ';')
ok $([ -z "$extra" ]; echo $?) "every documented route exists in the daemon ${extra:+(not served: $extra)}"

# Live: each documented operation is routed (not 404 for the path, not 405).
gd_start "$tmp/state" --slots 1
SC='{"method":"ed","dimensions":2,"particles":{"count":100,"volume_fraction":0.2},"run":{"until":{"time":0.05}}}'
id=$(field "$(post /api/v1/jobs -d "$SC")" 'd["id"]')
wait_state "$id" succeeded 30
while read -r m p; do
	path=$(echo "$p" | sed "s/{id}/$id/; s|presets/{name}|presets/cooling-2d|; s|static/{name}|static/app.js|; s/{name}/scene.json/")
	case "$m $p" in
	*/events) code=$(curl -s -m 3 -o /dev/null -w '%{http_code}' "$URL$path") ;;   # streams: the status is enough
	"POST /api/v1/jobs") post "$path" -d "$SC" >/dev/null; code=$(code) ;;
	POST*|DELETE*) api "$m" "$path" -H "Authorization: Bearer $TOKEN" >/dev/null; code=$(code) ;;
	*) api "$m" "$path" >/dev/null; code=$(code) ;;
	esac
	# /cancel of a finished job answers 409 and DELETE 200: routed either way.
	ok $([ "$code" != 404 ] && [ "$code" != 405 ] && [ "$code" != 000 ]; echo $?) "$m $path answers $code"
done <"$tmp/order"
gd_stop
finish
