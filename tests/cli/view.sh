#!/usr/bin/env bash
# `pdrmesh view`: a PNG and an SVG of a mesh's cut, of the requested size, with
# pixels in the angle colours (decoded here with Python's zlib, not compared to a
# stored picture) and the shaded boundary; its usage errors; the same bytes twice;
# and the histogram of `quality --svg` on a logarithmic axis with the tails' shares.
# Usage: view.sh PDRMESH SURFACE
set -euo pipefail
pdrmesh=$1 surface=$2
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT

"$pdrmesh" mesh -q "$surface" -o "$tmp/m.vtu"
"$pdrmesh" validate "$tmp/m.vtu" --surface "$surface" > /dev/null

"$pdrmesh" view "$tmp/m.vtu" -o "$tmp/cut.png" --width 400 --height 300 2> "$tmp/view.err"
grep -E "^cut z = .*: [1-9][0-9]* tets cut, [1-9][0-9]* boundary triangles behind" "$tmp/view.err" \
  || { cat "$tmp/view.err"; exit 1; }
python3 - "$tmp/cut.png" 400 300 <<'PY'
import struct, sys, zlib
data = open(sys.argv[1], "rb").read()
want_w, want_h = int(sys.argv[2]), int(sys.argv[3])
assert data[:8] == b"\x89PNG\r\n\x1a\n", "not a PNG signature"
pos, idat, ihdr = 8, b"", None
while pos < len(data):
    n, kind = struct.unpack(">I4s", data[pos:pos + 8])
    body = data[pos + 8:pos + 8 + n]
    assert zlib.crc32(kind + body) == struct.unpack(">I", data[pos + 8 + n:pos + 12 + n])[0], "bad CRC"
    if kind == b"IHDR": ihdr = struct.unpack(">IIBBBBB", body)
    if kind == b"IDAT": idat += body
    pos += 12 + n
w, h, depth, colour = ihdr[:4]
assert (w, h) == (want_w, want_h), (w, h)
assert depth == 8 and colour == 2, "expected 8-bit RGB"
raw, stride, rows, prev = zlib.decompress(idat), 3 * w, [], bytearray(3 * w)
for y in range(h):
    f, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
    for i in range(stride):
        a = line[i - 3] if i >= 3 else 0
        b, c = prev[i], prev[i - 3] if i >= 3 else 0
        if f == 1: line[i] = (line[i] + a) & 255
        elif f == 2: line[i] = (line[i] + b) & 255
        elif f == 3: line[i] = (line[i] + (a + b) // 2) & 255
        elif f == 4:
            p = a + b - c; pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
            line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
    rows.append(line); prev = line
pixels = [tuple(r[3 * x:3 * x + 3]) for r in rows for x in range(w)]
coloured = sum(1 for p in pixels if max(p) - min(p) > 60)   # the cut's angle colours
grey = sum(1 for p in pixels if max(p) - min(p) < 40 and 60 < sum(p) / 3 < 215)  # the shaded boundary
assert coloured > w * h // 50, f"only {coloured} coloured pixels"
assert grey > w * h // 200, f"only {grey} shaded pixels"
print(f"ok: {w}x{h} PNG, {coloured} coloured and {grey} shaded pixels")
PY

"$pdrmesh" view -q "$tmp/m.vtu" -o "$tmp/cut.svg" --plane x --width 500 --height 350
grep -q '<svg xmlns="http://www.w3.org/2000/svg" width="500" height="350"' "$tmp/cut.svg"
[ "$(grep -c '<polygon' "$tmp/cut.svg")" -gt 100 ] || { echo "too few polygons"; exit 1; }
grep -q "cut x = " "$tmp/cut.svg"
"$pdrmesh" view -q "$tmp/m.vtu" -o "$tmp/again.svg" --plane x --width 500 --height 350
cmp "$tmp/cut.svg" "$tmp/again.svg"
echo "ok: SVG of the requested size, the same bytes twice"

set +e
"$pdrmesh" view "$tmp/m.vtu" -o "$tmp/a.png" --plane w=1 2> "$tmp/err"; rc=$?
[ $rc -eq 64 ] && grep -q "x, y, z or AXIS=VALUE" "$tmp/err" || { echo "bad plane: exit $rc"; cat "$tmp/err"; exit 1; }
"$pdrmesh" view "$tmp/m.vtu" -o "$tmp/a.jpg" 2> "$tmp/err"; rc=$?
[ $rc -eq 64 ] && grep -q ".svg or .png" "$tmp/err" || { echo "bad suffix: exit $rc"; cat "$tmp/err"; exit 1; }
"$pdrmesh" view "$tmp/m.vtu" -o "$tmp/a.png" --plane z=1e9 2> "$tmp/err"; rc=$?
[ $rc -eq 65 ] && grep -q "misses the mesh" "$tmp/err" || { echo "plane outside: exit $rc"; cat "$tmp/err"; exit 1; }
set -e
echo "ok: usage errors"

"$pdrmesh" quality "$tmp/m.vtu" --svg "$tmp/h.svg" > /dev/null
grep -q "angles (log scale)" "$tmp/h.svg"
grep -q "&lt; 10&#176;: [0-9.]*% of tets" "$tmp/h.svg"
grep -q "&gt; 165&#176;: [0-9.]*% of tets" "$tmp/h.svg"
[ "$(grep -c 'text-anchor="middle">[0-9]*</text>' "$tmp/h.svg")" -eq 19 ] || { echo "expected 19 bin-edge labels"; exit 1; }
echo "ok: histogram on a log axis, tails written, labels at the 19 bin edges"
