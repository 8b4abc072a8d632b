#!/usr/bin/env bash
# The command line's usage errors: every bad option value, option combination
# and output path is refused with exit 64 and a message that names the option,
# what it accepts and what it got, before any file is read (the surface named
# does not exist: reaching it would exit 66), and no coordinator is needed to
# refuse them. Also: a mistyped command gets a suggestion, `help CMD` and
# `CMD --help` show the examples and exit codes, --time-limit bounds mesh and
# run, errors name files by the path given, and `check` counts holes.
# Usage: options.sh PDRMESH SURFACE
set -uo pipefail
pdrmesh=$1 surface=$2
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
unset PDRMESH_SERVER PDRMESH_TOKEN PDRMESH_TOKEN_FILE PDRMESH_CONFIG
export XDG_CONFIG_HOME=$tmp/config
missing=$tmp/missing.stl
failures=0
expect() {  # expect CODE TEXT -- command...: exit CODE and TEXT (fixed string) in stdout+stderr
  local code=$1 text=$2; shift 3
  local out rc
  out=$("$@" 2>&1); rc=$?
  if [[ $rc -ne $code ]] || ! grep -qF -- "$text" <<<"$out" || [[ ${#out} -gt 2000 && $code == 64 ]]; then
    echo "FAIL: '$*' gave exit $rc (want $code), output must contain '$text':"; echo "$out"
    failures=$((failures + 1))
  else
    echo "ok: $* -> $rc"
  fi
}
size_msg="must be a positive length or a percentage of the bounding-box diagonal such as 1%"

# Numbers: out of range, not numbers, not finite, overflowing.
for v in -1 0 abc 1e400 nan inf 0% 101% 1%% ''; do
  expect 64 "--size: $size_msg, got '$v'" -- "$pdrmesh" mesh "$missing" -o "$tmp/x.vtu" --size "$v"
done
expect 64 "--size: $size_msg, got 'nan'" -- "$pdrmesh" run "$missing" -o "$tmp/x.vtu" --size nan
for v in nan -1 0 abc; do
  expect 64 "--hmax: must be a positive length, got '$v'" -- "$pdrmesh" mesh "$missing" -o "$tmp/x.vtu" --hmax "$v"
  expect 64 "--hmin: must be a positive length, got '$v'" -- "$pdrmesh" run "$missing" -o "$tmp/x.vtu" --hmin "$v"
done
for v in 1 0.5 nan; do
  expect 64 "--growth: must be a growth factor greater than 1" -- "$pdrmesh" mesh "$missing" -o "$tmp/x.vtu" --growth "$v"
done
for v in 0 -2 2.5 1e400 abc 5000; do
  expect 64 "--workers: must be a whole number from 1 to 4096, got '$v'" -- "$pdrmesh" run "$missing" -o "$tmp/x.vtu" --workers "$v"
done
expect 64 "--depth: must be a whole number from 0 to 10, got '11'" -- "$pdrmesh" run "$missing" -o "$tmp/x.vtu" --depth 11
for cmd in mesh run; do
  expect 64 "--time-limit: must be a positive number of seconds, got '0'" -- "$pdrmesh" $cmd "$missing" -o "$tmp/x.vtu" --time-limit 0
  expect 64 "--time-limit: must be a positive number of seconds, got 'nan'" -- "$pdrmesh" $cmd "$missing" -o "$tmp/x.vtu" --time-limit nan
done
expect 64 "--max-volume: must be a positive volume, got '-1'" -- "$pdrmesh" mesh "$missing" -o "$tmp/x.vtu" --no-refine --max-volume -1

# Options that do not go together.
expect 64 "--hmin 2 is larger than --hmax 1" -- "$pdrmesh" mesh "$missing" -o "$tmp/x.vtu" --hmin 2 --hmax 1
expect 64 "--hmin 2 is larger than --hmax 1" -- "$pdrmesh" run "$missing" -o "$tmp/x.vtu" --hmin 2 --hmax 1
expect 64 "--max-volume: only with --no-refine" -- "$pdrmesh" mesh "$missing" -o "$tmp/x.vtu" --max-volume 1
expect 64 "--no-refine and --size do not go together" -- "$pdrmesh" mesh "$missing" -o "$tmp/x.vtu" --no-refine --size 1

# Output paths: the directory must exist and the suffix name a format.
expect 64 "--output: cannot write '/nonexistent/dir/x.vtu': the directory '/nonexistent/dir' does not exist" -- \
  "$pdrmesh" mesh "$missing" -o /nonexistent/dir/x.vtu
expect 64 "--output: $tmp/x.xyz: unknown volume mesh suffix" -- "$pdrmesh" run "$missing" -o "$tmp/x.xyz"
expect 64 "is a directory" -- "$pdrmesh" mesh "$missing" -o "$tmp"
expect 64 "--profile-json: cannot write" -- "$pdrmesh" run "$missing" -o "$tmp/x.vtu" --profile-json /nonexistent/p.json
expect 64 "--svg: cannot write" -- "$pdrmesh" quality "$tmp/missing.vtu" --svg /nonexistent/q.svg
expect 64 "OUT: cannot write" -- "$pdrmesh" convert "$tmp/missing.vtu" /nonexistent/x.vtu
expect 64 "unknown surface format" -- "$pdrmesh" mesh "$tmp/part.xyz" -o "$tmp/x.vtu"

# The service commands: the same checks, before any connection (no server is set).
expect 64 "--size: $size_msg, got '-1'" -- "$pdrmesh" submit "$missing" --size -1
expect 64 "--time-limit: must be a positive number of seconds, got 'abc'" -- "$pdrmesh" submit "$missing" --time-limit abc
expect 64 "--max-volume and --size do not go together" -- "$pdrmesh" submit "$missing" --max-volume 1 --size 1
expect 64 "--output: cannot write '/nonexistent/dir/s.msh'" -- "$pdrmesh" fetch J --output /nonexistent/dir/s.msh
expect 64 "--output: $tmp/s.xyz: unknown volume mesh suffix" -- "$pdrmesh" fetch J -o "$tmp/s.xyz"
expect 64 "--timeout: must be a positive number of seconds, got '0'" -- "$pdrmesh" list --timeout 0
expect 64 "--output is required" -- "$pdrmesh" fetch J --output-file "$tmp/s.msh"  # the old spelling is gone
expect 64 "no server" -- "$pdrmesh" fetch J --output "$tmp/s.msh"   # -o/--output parsed; nothing to connect to

# Commands: suggestions, help.
expect 64 "unknown command 'mesg'; did you mean 'mesh'?" -- "$pdrmesh" mesg
expect 64 "unknown command 'logs'; did you mean 'watch'?" -- "$pdrmesh" logs
expect 64 "unknown command 'qualty'; did you mean 'quality'?" -- "$pdrmesh" qualty
expect 64 "unknown command 'nosuch'" -- "$pdrmesh" help nosuch
expect 0 "--size" -- "$pdrmesh" help mesh
expect 0 "Exit codes:" -- "$pdrmesh" help mesh
expect 0 "pdrmesh mesh part.stl -o part.vtu" -- "$pdrmesh" help mesh
expect 0 "Examples:" -- "$pdrmesh" fetch --help
expect 0 "64  usage error" -- "$pdrmesh" submit --help
expect 0 "Usage: pdrmesh [OPTIONS] SUBCOMMAND" -- "$pdrmesh" help
expect 0 "Usage: pdrmesh fetch [OPTIONS] JOB" -- "$pdrmesh" help fetch
expect 64 "a command is required" -- "$pdrmesh"

# Errors name files by the path given; holes are counted as loops of open edges.
mkdir -p "$tmp/bad" && echo > "$tmp/bad/empty.stl"
expect 65 "$tmp/bad/empty.stl: empty file" -- "$pdrmesh" mesh "$tmp/bad/empty.stl" -o "$tmp/x.vtu"
expect 66 "$tmp/missing.stl" -- "$pdrmesh" check "$missing"
{  # three tetrahedra apart, each with one face missing: three holes of three open edges
  echo OFF; echo "12 9 0"
  for k in 0 3 6; do printf '%s 0 0\n%s 0 0\n%s 1 0\n%s 0 1\n' $k $((k + 1)) $k $k; done
  for b in 0 4 8; do printf '3 %d %d %d\n3 %d %d %d\n3 %d %d %d\n' $b $((b + 2)) $((b + 1)) $b $((b + 1)) $((b + 3)) $b $((b + 3)) $((b + 2)); done
} > "$tmp/three.off"
expect 65 "NOT meshable: 3 holes (9 open edges)" -- "$pdrmesh" check "$tmp/three.off"
expect 65 "hole 3 (3 open edges): edge 9-10 at (6.5, 0.5, 0)" -- "$pdrmesh" check "$tmp/three.off"
expect 65 "$tmp/bad/../three.off: the surface cannot be meshed: 3 holes (9 open edges)" -- \
  "$pdrmesh" mesh "$tmp/bad/../three.off" -o "$tmp/x.vtu" --size 1%
json=$("$pdrmesh" check --json "$tmp/three.off")
python3 -c 'import json,sys; j=json.loads(sys.argv[1]); assert j["hole_count"]==3 and len(j["holes"])==3 and j["defect_counts"]["open_edge"]==9, j' "$json" \
  || failures=$((failures + 1))

# --time-limit bounds the whole run: far too short, exit 75 and nothing written.
expect 75 "time limit" -- "$pdrmesh" mesh "$surface" -o "$tmp/t.vtu" --size 0.5% --time-limit 0.05
expect 75 "time limit" -- "$pdrmesh" run "$surface" -o "$tmp/t.vtu" --size 0.5% --time-limit 0.05
[[ ! -e $tmp/t.vtu ]] || { echo "FAIL: a run past its time limit wrote $tmp/t.vtu"; failures=$((failures + 1)); }

echo "$failures failure(s)"
[[ $failures == 0 ]]
