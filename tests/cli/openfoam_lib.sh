# SPDX-License-Identifier: AGPL-3.0-or-later
# Sourced by the CLI tests that run OpenFOAM: openfoam_env puts OpenFOAM's
# programs (checkMesh, potentialFoam, ...) on the PATH when it is installed
# (Debian's openfoam package, or an openfoam.com build under /usr/lib/openfoam).
openfoam_env() {
  local bashrc
  for bashrc in /usr/share/openfoam/etc/bashrc /usr/lib/openfoam/openfoam*/etc/bashrc; do
    if [[ -f $bashrc ]]; then
      # With no arguments: the bashrc reads any as settings to look up, and a
      # search for a test's own (a program path, a surface) took minutes.
      set +u; set --; source "$bashrc" >/dev/null 2>&1 || true; set -u
      break
    fi
  done
}

# checkmesh_case DIR: the system/ files checkMesh reads besides constant/polyMesh
# (controlDict, fvSchemes, fvSolution), written into the case DIR.
checkmesh_case() {
  mkdir -p "$1/system"
  cat >"$1/system/controlDict" <<'DICT'
FoamFile { version 2.0; format ascii; class dictionary; object controlDict; }
application checkMesh; startFrom startTime; startTime 0; stopAt endTime; endTime 1;
deltaT 1; writeControl timeStep; writeInterval 1;
DICT
  cat >"$1/system/fvSchemes" <<'DICT'
FoamFile { version 2.0; format ascii; class dictionary; object fvSchemes; }
ddtSchemes {} gradSchemes {} divSchemes {} laplacianSchemes {} interpolationSchemes {} snGradSchemes {}
DICT
  echo 'FoamFile { version 2.0; format ascii; class dictionary; object fvSolution; }' >"$1/system/fvSolution"
}
