#!/usr/bin/env bash
# SPDX-License-Identifier: AGPL-3.0-or-later
# Runs every libFuzzer target for SECONDS each, from seeds cut from tests/data, and prints
# a table: target, executions, exec/s, corpus size, crashes. Exit status 1 if any target crashed
# (the inputs are in BUILD/fuzz/crashes/<target>/: minimise one, add it to
# tests/fuzz/regressions/<target>/ and fix the bug).
#   tests/fuzz/run.sh SECONDS [TARGET...]
# Environment: FUZZ_BUILD_DIR (default build-asan: a clang build with PDRMESH_FUZZ=ON),
# FUZZ_JOBS (targets run at once, default nproc), PDRMESH_TEST_DATA (the test surfaces the seeds
# are cut from, default tests/data).
# The working corpus (BUILD/fuzz/corpus/<target>) is kept between runs, so runs add up.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
seconds=${1:?usage: tests/fuzz/run.sh SECONDS [TARGET...]}
shift
build=${FUZZ_BUILD_DIR:-$root/build-asan}
bin=$build/tests/fuzz
data=${PDRMESH_TEST_DATA:-$root/tests/data}
work=$build/fuzz
[[ -x $bin/pdrmesh_fuzz_seeds ]] || { echo "run.sh: no fuzz build in $build (clang, -DPDRMESH_FUZZ=ON)" >&2; exit 2; }

targets=("$@")
if ((${#targets[@]} == 0)); then
  for f in "$bin"/pdrmesh_fuzz_*; do
    t=${f##*/pdrmesh_fuzz_}
    [[ $t == seeds ]] || targets+=("$t")
  done
fi

rm -rf "$work/seeds"
"$bin/pdrmesh_fuzz_seeds" "$data" "$work/seeds" >/dev/null
# Leaks are real findings here (libFuzzer checks them per input); UBSan stops at the first report.
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:halt_on_error=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}

run_one() {
  local t=$1
  rm -rf "$work/crashes/$t"
  mkdir -p "$work/corpus/$t" "$work/crashes/$t" "$work/seeds/$t" "$work/logs"
  "$bin/pdrmesh_fuzz_$t" -max_total_time="$seconds" -timeout=20 -rss_limit_mb=2048 -max_len=65536 \
    -print_final_stats=1 -artifact_prefix="$work/crashes/$t/" "$work/corpus/$t" "$work/seeds/$t" \
    >"$work/logs/$t.log" 2>&1 || true
}
export -f run_one
export bin work seconds
printf '%s\n' "${targets[@]}" | xargs -P "${FUZZ_JOBS:-$(nproc)}" -I{} bash -c 'run_one {}'

status=0
printf '%-20s %12s %9s %8s %8s\n' target executions exec/s corpus crashes
for t in "${targets[@]}"; do
  log=$work/logs/$t.log
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
  size=$(find "$work/corpus/$t" -type f | wc -l)
  crashes=$(find "$work/crashes/$t" -type f | wc -l)
  if [[ -z $runs ]] && ((crashes == 0)); then crashes="?"; fi  # died before printing its stats
  printf '%-20s %12s %9s %8s %8s\n' "$t" "${runs:-?}" "${rate:-?}" "$size" "$crashes"
  if [[ $crashes != 0 ]]; then
    status=1
    echo "  $t: see $log and $work/crashes/$t/" >&2
  fi
done
exit $status
