#!/usr/bin/env bash
# SPDX-License-Identifier: AGPL-3.0-or-later
# Builds oneTBB with ThreadSanitizer into PREFIX, for the TSan stage of scripts/sanitize.sh.
# Debian's libtbb12 is not instrumented, so TSan cannot see the synchronisation of TBB's task
# hand-off and reports races on every task's data. This builds the very source Debian builds
# libtbb-dev from (onetbb 2021.8.0-2+deb12u1, from Debian's archive, checked against pinned
# SHA-256 sums, Debian's patches applied by dpkg-source), with clang-14 -fsanitize=thread.
#   scripts/tsan-tbb.sh PREFIX        (then: cmake ... -DTBB_DIR=PREFIX/lib/cmake/TBB)
# Environment: DEBIAN_MIRROR (default http://deb.debian.org/debian). Does nothing when PREFIX
# already holds this version. About a minute on 2 cores.
set -euo pipefail
prefix=${1:?usage: scripts/tsan-tbb.sh PREFIX}
version=2021.8.0-2+deb12u1
stamp=$prefix/.pdrmesh-tsan-tbb-$version
[[ -f $stamp ]] && exit 0

mirror=${DEBIAN_MIRROR:-http://deb.debian.org/debian}
files=(
  "onetbb_$version.dsc f01de0ed79cb49b48beb2cdb6e1b3c5f625ca65f07d7959bebfbbd89a2e941ad"
  "onetbb_2021.8.0.orig.tar.xz 7e9111b8bb59c8800bf6d0b06afe7b0891937443d2dae1ee1101c8e2ede6a7ef"
  "onetbb_$version.debian.tar.xz b83a270205b38cdf66972fa1467c3e29493b88b92ecacf4f3672e87d67199df5"
)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for entry in "${files[@]}"; do
  read -r name sum <<<"$entry"
  curl -fsS --retry 3 -o "$work/$name" "$mirror/pool/main/o/onetbb/$name" ||
    { echo "tsan-tbb: cannot download $mirror/pool/main/o/onetbb/$name" >&2; exit 1; }
  echo "$sum  $work/$name" | sha256sum --quiet -c - ||
    { echo "tsan-tbb: $name does not match its pinned SHA-256" >&2; exit 1; }
done
# The .dsc's signature is not checked (the keyring may be missing); the pinned sums stand for it.
(cd "$work" && dpkg-source --no-check -x "onetbb_$version.dsc" src >/dev/null)
cmake -S "$work/src" -B "$work/build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_COMPILER=clang++-14 -DTBB_SANITIZE=thread -DTBB_TEST=OFF -DTBB_STRICT=OFF \
  -DTBBMALLOC_BUILD=OFF -DTBB_DISABLE_HWLOC_AUTOMATIC_SEARCH=ON -DCMAKE_INSTALL_PREFIX="$prefix" >/dev/null
cmake --build "$work/build" --parallel "$(nproc)" >/dev/null
cmake --install "$work/build" >/dev/null
touch "$stamp"
echo "tsan-tbb: oneTBB $version with ThreadSanitizer in $prefix"
