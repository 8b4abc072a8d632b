#!/usr/bin/env bash
# Strong scaling of the parallel mesher against the serial one on one surface: `pdrmesh mesh`,
# then `pdrmesh run --workers N` for each N, all in one run on one machine.
#   bench/scaling.sh [SIZE] [SURFACE] [WORKERS...]   defaults: 0.3% armadillo 1 2 4 8 16
# Columns: command, tets, parallel/serial tet ratio, wall and CPU seconds, peak memory (max RSS)
# per tet, all-tet and interior dihedral extremes, speedup over the serial mesher and over one
# worker, and "=" when the mesh has the same bytes as the first parallel run's.
# Times come from the kernel's accounting of the child (Python's os.wait4), so the script needs no
# GNU time. PDRMESH=path picks the program; PROFILE_DIR=DIR keeps each run's profile for
# pdrmesh_bench_replay. Surfaces from $PDRMESH_CORPUS (default bench/corpus: bench/fetch-corpus.sh).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
corpus=${PDRMESH_CORPUS:-$root/bench/corpus}
pdrmesh=${PDRMESH:-$root/build/client/pdrmesh}
size=${1:-0.3%}
name=${2:-armadillo}
shift 2 || shift $#
workers=("$@"); ((${#workers[@]})) || workers=(1 2 4 8 16)
surface=$corpus/$name.stl
[[ -f $surface ]] || { echo "no $surface: run bench/fetch-corpus.sh" >&2; exit 1; }
tmp=$(mktemp -d "${TMPDIR:-/tmp}/pdrmesh-scaling.XXXXXX"); trap 'rm -rf "$tmp"' EXIT

# measure NAME command...: runs the command with its result JSON on stdout into NAME.json and
# its wall seconds, CPU seconds and max RSS (bytes) into NAME.t.
measure() {
  local out=$1; shift
  python3 - "$out" "$@" <<'PY'
import os, subprocess, sys, time
out, cmd = sys.argv[1], sys.argv[2:]
start = time.monotonic()
with open(out + ".json", "w") as stdout, open(out + ".err", "w") as stderr:
    pid = subprocess.Popen(cmd, stdout=stdout, stderr=stderr).pid
    _, status, usage = os.wait4(pid, 0)
wall = time.monotonic() - start
if os.waitstatus_to_exitcode(status) != 0:
    sys.exit(f"failed: {' '.join(cmd)}: {open(out + '.err').read().strip().splitlines()[-1:]}")
with open(out + ".t", "w") as f:
    f.write(f"{wall} {usage.ru_utime + usage.ru_stime} {usage.ru_maxrss * 1024}\n")
PY
}

echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(awk '/MemTotal/ { printf "%.1f GiB", $2 / 1048576 }' /proc/meminfo); $(date -u +%F); load $(cut -d' ' -f1-3 /proc/loadavg)"
echo "surface: $name.stl, --size $size; serial: pdrmesh mesh; parallel: pdrmesh run --workers N"
measure "$tmp/serial" "$pdrmesh" mesh -q --json "$surface" -o "$tmp/serial.meshb" --size "$size"
runs=(serial)
for n in "${workers[@]}"; do
  prof=(); [[ -n ${PROFILE_DIR:-} ]] && mkdir -p "$PROFILE_DIR" && prof=(--profile-json "$PROFILE_DIR/scaling.$name.$size.w$n.json")
  measure "$tmp/w$n" "$pdrmesh" run -q --json "$surface" -o "$tmp/w$n.meshb" --size "$size" --workers "$n" "${prof[@]}"
  runs+=("w$n")
done
for r in "${runs[@]}"; do "$pdrmesh" quality --json "$tmp/$r.meshb" >"$tmp/$r.q"; done

python3 - "$tmp" "${runs[@]}" <<'PY'
import filecmp, json, os, sys
tmp, runs = sys.argv[1], sys.argv[2:]
rows = {}
for r in runs:
    wall, cpu, rss = (float(x) for x in open(os.path.join(tmp, r + ".t")).read().split())
    rows[r] = (json.load(open(os.path.join(tmp, r + ".json"))), wall, cpu, rss)
serial_tets, serial_wall = rows["serial"][0]["tets"], rows["serial"][1]
first = next((r for r in runs if r != "serial"), None)
one = rows.get("w1")
print(f"{'command':<18} {'tets':>11} {'ratio':>6} {'wall_s':>7} {'cpu_s':>7} {'B/tet':>6} "
      f"{'min/max':>13} {'int_min/max':>13} {'vs_mesh':>7} {'vs_w1':>6} same")
for r in runs:
    res, wall, cpu, rss = rows[r]
    q = json.load(open(os.path.join(tmp, r + ".q")))
    label = "mesh" if r == "serial" else f"run --workers {r[1:]}"
    same = "" if r == "serial" else ("=" if filecmp.cmp(os.path.join(tmp, first + ".meshb"),
                                                        os.path.join(tmp, r + ".meshb"), shallow=False) else "no")
    vs_w1 = f"{one[1] / wall:6.2f}" if one and r != "serial" else f"{'':>6}"
    print(f"{label:<18} {res['tets']:>11,} {res['tets'] / serial_tets:6.3f} {wall:7.2f} {cpu:7.2f} "
          f"{rss / res['tets']:6.0f} {q['min_dihedral']:6.2f}/{q['max_dihedral']:6.2f} "
          f"{q['interior_min_dihedral']:6.2f}/{q['interior_max_dihedral']:6.2f} {serial_wall / wall:7.2f} {vs_w1} {same}")
PY
