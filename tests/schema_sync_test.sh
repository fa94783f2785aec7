#!/bin/sh
# Keeps schema/scene.schema.json in step with the parser: good scenes valid, bad scenes invalid unless marked schema-ok (TAP).
SRCDIR=${SRCDIR:-$(cd "$(dirname "$0")/.." && pwd)}
PY=/usr/bin/python3

if ! "$PY" -c 'import jsonschema' 2>/dev/null; then
	echo "1..0 # SKIP python3-jsonschema not installed"
	exit 0
fi

exec "$PY" - "$SRCDIR" <<'EOF'
import json, os, sys
import jsonschema

srcdir = sys.argv[1]
scenes = os.path.join(srcdir, "tests", "scenes")
results = []

def check(cond, what):
    results.append((bool(cond), what))

def no_duplicates(pairs):
    # The parser rejects duplicate keys; Python would keep the last one.
    keys = [k for k, _ in pairs]
    if len(keys) != len(set(keys)):
        raise ValueError("duplicate key")
    return dict(pairs)

def load(path):
    """The scene, or None when it is not JSON (the schema cannot accept it)."""
    try:
        with open(path, encoding="utf-8") as f:
            return json.loads(f.read(), object_pairs_hook=no_duplicates)
    except ValueError:
        return None

with open(os.path.join(srcdir, "schema", "scene.schema.json"), encoding="utf-8") as f:
    schema = json.load(f)
try:
    jsonschema.Draft202012Validator.check_schema(schema)
    check(True, "schema is a valid draft 2020-12 schema")
except jsonschema.SchemaError as e:
    check(False, "schema is a valid draft 2020-12 schema: %s" % e.message)
validator = jsonschema.Draft202012Validator(schema)

good = os.path.join(scenes, "good")
for name in sorted(os.listdir(good)):
    if not name.endswith(".json"):
        continue
    doc = load(os.path.join(good, name))
    errs = list(validator.iter_errors(doc)) if doc is not None else ["not JSON"]
    check(not errs, "good/%s is valid%s" % (name, "" if not errs else ": %s" % getattr(errs[0], "message", errs[0])))

bad = os.path.join(scenes, "bad")
listed = set()
with open(os.path.join(bad, "expected.tsv"), encoding="utf-8") as f:
    for line in f:
        cols = line.rstrip("\n").split("\t")
        if len(cols) < 2:
            continue
        name, schema_ok = cols[0], len(cols) > 2 and cols[2] == "schema-ok"
        listed.add(name)
        path = os.path.join(bad, name)
        if not os.path.exists(path):
            check(False, "bad/%s exists" % name)
            continue
        doc = load(path)
        valid = doc is not None and validator.is_valid(doc)
        if schema_ok:
            # Only the parser can reject it; if the schema learns to, drop the mark.
            check(valid, "bad/%s is accepted by the schema (schema-ok: parser-only rule)" % name)
        else:
            check(not valid, "bad/%s is rejected by the schema" % name)

for name in sorted(os.listdir(bad)):
    if name.endswith(".json"):
        check(name in listed, "bad/%s is listed in expected.tsv" % name)

print("1..%d" % len(results))
for i, (cond, what) in enumerate(results, 1):
    print("%sok %d - %s" % ("" if cond else "not ", i, what))
sys.exit(0 if all(c for c, _ in results) else 1)
EOF
