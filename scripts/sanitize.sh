#!/usr/bin/env bash
# SPDX-License-Identifier: AGPL-3.0-or-later
# The sanitizer and fuzz stage of scripts/test.sh (run after the normal build and ctest):
#  1. build-asan: clang-14, AddressSanitizer + UndefinedBehaviorSanitizer (UBSan stops at the
#     first report) and the libFuzzer targets; the ctest suite there (less the labels openfoam
#     and no_sanitizers), including the replay of tests/fuzz/regressions; then every fuzz target
#     for FUZZ_SECONDS (default 5) each.
#  2. build-tsan: clang-14, ThreadSanitizer, linked against oneTBB built with TSan from Debian's
#     own source (scripts/tsan-tbb.sh: Debian's libtbb12 is not instrumented, so TSan could not
#     see TBB's task hand-off). pdrmesh_thread_tests (tests/pdr/scheduler_test.cpp and
#     tests/pdr/pdr_test.cpp: the lock table, the coloured and dynamic schedulers running leaves on
#     several threads, the engine's parallel runs and merge; TSAN_FILTER narrows it) and
#     pdrmesh_coordinator_thread_tests (tests/service/job_manager_test.cpp: the coordinator's
#     runner threads, jobs of two users at once with the engine's leaf threads, cancel, delete
#     and a reader thread). The gRPC service tests are not run under TSan: Debian's gRPC and
#     protobuf are not instrumented (about 2,800 reports, all through gRPC's hand-off).
#     PDRMESH_TSAN=0 skips this part.
# Any sanitizer report fails the stage. Set PDRMESH_SANITIZERS=0 to skip it (scripts/test.sh).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
jobs=$(nproc)
# Unity builds (see scripts/build.sh): these trees are always built whole.
clang=(-DCMAKE_C_COMPILER=clang-14 -DCMAKE_CXX_COMPILER=clang++-14 -DCMAKE_UNITY_BUILD=ON)
t0=$SECONDS

# Reports go to stderr of the process that has them; the TetGen helper (pdrmesh-tetgen, built with
# the same sanitizers) writes its stderr to its log, dies with exitcode 1 and its parent fails the
# test with that log. detect_leaks=1: a leak at exit fails a test process. The helper ends with
# _exit(), which skips the leak check, so memory TetGen owns at that point is never reported (a
# process about to vanish). Suppressions are for third-party code only, each with its reason.
sup=$root/tests/sanitizers
export ASAN_OPTIONS="detect_leaks=1:halt_on_error=1:detect_stack_use_after_return=0:strict_string_checks=1"
export LSAN_OPTIONS="suppressions=$sup/lsan.supp:print_suppressions=0"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1:suppressions=$sup/ubsan.supp"
export TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1:suppressions=$sup/tsan.supp"

echo "sanitize: ASan+UBSan build (build-asan)"
cmake -S "$root" -B "$root/build-asan" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo "${clang[@]}" \
  -DPDRMESH_SANITIZE=address,undefined -DPDRMESH_FUZZ=ON >/dev/null
cmake --build "$root/build-asan" --parallel "$jobs"
echo "sanitize: ASan+UBSan ctest ($((SECONDS - t0)) s so far)"
# Every test, the service and corpus ones included: TetGen runs in a helper program started by
# posix_spawn (tetgen_adapter.cpp), so a lock that another thread holds cannot reach it (LLVM 14's
# ASan allocator is not fork-safe; a bare fork() of TetGen beside busy threads used to hang here).
# Except the OpenFOAM/CGNS checks (label openfoam): their time is checkMesh's and cgnscheck's, and
# the writers they exercise run under the sanitizers in the io unit tests; and the slowest
# end-to-end tests (label no_sanitizers, see tests/CMakeLists.txt), whose code the others cover.
(cd "$root/build-asan" && ctest --output-on-failure --parallel "$jobs" --timeout 900 -LE "openfoam|no_sanitizers")
echo "sanitize: fuzzing, ${FUZZ_SECONDS:-5} s per target ($((SECONDS - t0)) s so far)"
FUZZ_BUILD_DIR=$root/build-asan "$root/tests/fuzz/run.sh" "${FUZZ_SECONDS:-5}"

if [[ ${PDRMESH_TSAN:-1} == 0 ]]; then
  echo "sanitize: TSan stage skipped (PDRMESH_TSAN=0); done in $((SECONDS - t0)) s"
  exit 0
fi
echo "sanitize: TSan build (build-tsan, the threaded tests only; $((SECONDS - t0)) s so far)"
"$root/scripts/tsan-tbb.sh" "$root/build-tsan/tsan-tbb"
cmake -S "$root" -B "$root/build-tsan" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo "${clang[@]}" \
  -DPDRMESH_SANITIZE=thread -DTBB_DIR="$root/build-tsan/tsan-tbb/lib/cmake/TBB" >/dev/null
cmake --build "$root/build-tsan" --parallel "$jobs" --target pdrmesh_thread_tests pdrmesh_coordinator_thread_tests
# Not `ldd | grep -q`: grep -q exits at the first match, and under pipefail
# ldd's SIGPIPE then fails the check (it did, once, on a loaded machine).
if ! grep -q "build-tsan/tsan-tbb/lib/libtbb" <<<"$(ldd "$root/build-tsan/tests/pdrmesh_thread_tests")"; then
  echo "sanitize: build-tsan is not linked against the instrumented oneTBB" >&2
  exit 1
fi
echo "sanitize: TSan tests ($((SECONDS - t0)) s so far)"
"$root/build-tsan/tests/pdrmesh_thread_tests" --gtest_brief=1 ${TSAN_FILTER:+--gtest_filter="$TSAN_FILTER"}
"$root/build-tsan/tests/service/pdrmesh_coordinator_thread_tests" --gtest_brief=1
echo "sanitize: done in $((SECONDS - t0)) s"
