#!/usr/bin/env bash
# SPDX-License-Identifier: AGPL-3.0-or-later
# Writes real secrets for the example overlay into DIR (default: overlays/example/secrets):
# a tokens file with one random token per USER (default: alice), a random cluster token, and a
# private CA (ECDSA P-256, 825 days) with the coordinator's, the workers' and the client port's
# certificates. Existing files are overwritten. Keep DIR out of version control.
#   deploy/k8s/gen-secrets.sh [DIR] [USER...]
# Extra subject names: PDRMESH_CLIENT_SANS (default DNS:pdrmesh-coordinator,DNS:localhost,
# IP:127.0.0.1), PDRMESH_COORDINATOR_SANS (default DNS:pdrmesh-coordinator-workers),
# PDRMESH_WORKER_SANS (default DNS:pdrmesh-worker).
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
dir=${1:-$here/overlays/example/secrets}
shift || true
users=("$@")
((${#users[@]})) || users=(alice)
command -v openssl >/dev/null || { echo "gen-secrets: openssl not found (apt-get install openssl)" >&2; exit 1; }
mkdir -p "$dir"
umask 077
random() { head -c 32 /dev/urandom | od -An -vtx1 | tr -d ' \n'; }

{ echo "# user token (generated $(date -u +%FT%TZ))"; for u in "${users[@]}"; do echo "$u $(random)"; done; } >"$dir/tokens"
random >"$dir/cluster-token"; echo >>"$dir/cluster-token"

ec() { openssl genpkey -algorithm EC -pkeyopt ec_paramgen_curve:P-256 -out "$1" 2>/dev/null; }
ec "$dir/ca.key"
openssl req -x509 -new -key "$dir/ca.key" -subj "/CN=pdrmesh CA" -days 825 -out "$dir/ca.crt" \
  -addext "basicConstraints=critical,CA:TRUE" -addext "keyUsage=critical,keyCertSign,cRLSign" 2>/dev/null
issue() {  # issue NAME CN SANS EXTENDED_KEY_USAGE
  ec "$dir/$1.key"
  openssl req -new -key "$dir/$1.key" -subj "/CN=$2" -out "$dir/$1.csr" 2>/dev/null
  openssl x509 -req -in "$dir/$1.csr" -CA "$dir/ca.crt" -CAkey "$dir/ca.key" -CAcreateserial \
    -days 825 -out "$dir/$1.crt" \
    -extfile <(printf 'subjectAltName=%s\nextendedKeyUsage=%s\nkeyUsage=critical,digitalSignature\n' "$3" "$4") 2>/dev/null
  rm -f "$dir/$1.csr"
}
issue coordinator pdrmesh-coordinator "${PDRMESH_COORDINATOR_SANS:-DNS:pdrmesh-coordinator-workers}" serverAuth,clientAuth
issue worker pdrmesh-worker "${PDRMESH_WORKER_SANS:-DNS:pdrmesh-worker}" serverAuth,clientAuth
issue client-port pdrmesh-coordinator "${PDRMESH_CLIENT_SANS:-DNS:pdrmesh-coordinator,DNS:localhost,IP:127.0.0.1}" serverAuth
rm -f "$dir/ca.srl"
echo "gen-secrets: wrote tokens (${users[*]}), cluster-token, ca.crt/ca.key and coordinator, worker, client-port certificates to $dir" >&2
echo "gen-secrets: ca.key is not used by the overlay: keep it somewhere safe, off the cluster" >&2
