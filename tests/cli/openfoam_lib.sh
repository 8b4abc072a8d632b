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

# flow_fields DIR BODY_PATCH BODY_U U0: 0/U and 0/p of a flow along +x in a
# far-field box (patches inlet, outlet, sides): U = (1 0 0) at the inlet, p = 0
# at the outlet, slip sides; at the body U of type BODY_U (slip, noSlip) and
# p zeroGradient; the internal U is U0, e.g. "(0 0 0)".
flow_fields() {
  local dir=$1 body=$2 body_u=$3 u0=$4
  mkdir -p "$dir/0"
  cat >"$dir/0/U" <<DICT
FoamFile { version 2.0; format ascii; class volVectorField; object U; }
dimensions [0 1 -1 0 0 0 0];
internalField uniform $u0;
boundaryField
{
    inlet { type fixedValue; value uniform (1 0 0); }
    outlet { type zeroGradient; }
    sides { type slip; }
    $body { type $body_u; }
}
DICT
  cat >"$dir/0/p" <<DICT
FoamFile { version 2.0; format ascii; class volScalarField; object p; }
dimensions [0 2 -2 0 0 0 0];
internalField uniform 0;
boundaryField
{
    inlet { type zeroGradient; }
    outlet { type fixedValue; value uniform 0; }
    sides { type zeroGradient; }
    $body { type zeroGradient; }
}
DICT
}
