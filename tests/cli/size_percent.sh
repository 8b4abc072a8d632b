#!/usr/bin/env bash
# --size as a percentage of the bounding-box diagonal: `mesh --size 1%` gives
# the same bytes as `mesh --size D/100` with D the diagonal, says the spacing
# it used (and how far it rises next to wider triangles), and both meshes
# validate against the surface; `run` takes it too.
# Usage: size_percent.sh PDRMESH SURFACE (a Medit .mesh surface)
set -euo pipefail
pdrmesh=$1 surface=$2
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT

"$pdrmesh" mesh "$surface" -o "$tmp/pct.meshb" --size 1% --json > "$tmp/pct.json" 2> "$tmp/pct.err"
# (The surface's triangles are wider than 1%: the line says how far the size rises next to them.)
grep -E "size: [0-9.]+ \(1% of the bounding-box diagonal [0-9.]+\); up to [0-9.e+-]+ next to surface triangles wider than it \(--hmax [0-9.e+-]+ keeps it there too\)$" "$tmp/pct.err" \
  || { echo "no size line:"; cat "$tmp/pct.err"; exit 1; }
# The size the run used, exactly (JSON doubles round-trip), and the diagonal worked out here.
size=$(python3 - "$tmp/pct.json" "$surface" <<'PY'
import json, math, sys
j = json.load(open(sys.argv[1]))
assert isinstance(j["tets"], int) and j["tets"] > 0 and isinstance(j["points"], int), j
words = open(sys.argv[2]).read().split()
i = words.index("Vertices"); n = int(words[i + 1])
pts = [tuple(float(w) for w in words[i + 2 + 4 * k:i + 5 + 4 * k]) for k in range(n)]
diag = math.sqrt(sum((max(p[a] for p in pts) - min(p[a] for p in pts)) ** 2 for a in range(3)))
assert abs(j["size"] - diag / 100) <= 1e-12 * diag, (j["size"], diag / 100)
print(repr(j["size"]))
PY
)
"$pdrmesh" mesh -q "$surface" -o "$tmp/abs.meshb" --size "$size"
cmp "$tmp/pct.meshb" "$tmp/abs.meshb"
"$pdrmesh" validate "$tmp/pct.meshb" --surface "$surface" > /dev/null
echo "ok: mesh --size 1% is mesh --size $size, byte for byte, and validates"

"$pdrmesh" run "$surface" -o "$tmp/run_pct.meshb" --size 4% --depth 1 --workers 2 --json > "$tmp/run.json" 2> "$tmp/run.err"
grep -q "(4% of the bounding-box diagonal" "$tmp/run.err" || { cat "$tmp/run.err"; exit 1; }
size2=$(python3 -c 'import json,sys; j=json.load(open(sys.argv[1])); assert abs(j["size"] - 4 * float(sys.argv[2])) < 1e-12 * j["size"]; print(repr(j["size"]))' "$tmp/run.json" "$size")
"$pdrmesh" run -q "$surface" -o "$tmp/run_abs.meshb" --size "$size2" --depth 1 --workers 2
cmp "$tmp/run_pct.meshb" "$tmp/run_abs.meshb"
"$pdrmesh" validate "$tmp/run_pct.meshb" --surface "$surface" > /dev/null
echo "ok: run --size 4% is run --size 4*D/100 and validates"

# The default size: said as the surface's own spacing.
"$pdrmesh" mesh "$surface" -o "$tmp/default.meshb" 2> "$tmp/default.err"
grep -E "size: from the surface \(h from [0-9.e-]+ to [0-9.e-]+\)$" "$tmp/default.err" || { cat "$tmp/default.err"; exit 1; }
"$pdrmesh" validate "$tmp/default.meshb" --surface "$surface" > /dev/null
echo "ok: the default size is reported"
