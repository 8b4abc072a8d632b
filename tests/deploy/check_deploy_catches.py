#!/usr/bin/python3
# SPDX-License-Identifier: AGPL-3.0-or-later
# check_deploy.py fails where it should: on a copy of deploy/ with one defect each (a probe on an
# undeclared port, a Service targetPort that no container has, an unknown flag in an env file, in
# a Kubernetes arg or in up.sh, a grace period shorter than the drain, a missing hardening option,
# a Secret key that does not exist, a --coordinator that is no Service port, a writable root
# filesystem, a YAML syntax error, an unknown systemd key), and passes on the unchanged copy.
# The daemons are stand-ins whose --help lists the flags agreed in the daemon-flags brief.
# Usage: check_deploy_catches.py REPO_ROOT
import concurrent.futures
import os
import shutil
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
COORDINATOR_FLAGS = ("--listen --data-dir --tokens --max-upload-bytes --max-queued-jobs --max-running-jobs "
                     "--threads --default-time-limit --max-time-limit --tls-cert --tls-key --allow-insecure "
                     "--log-level --worker-listen --workers --cluster-token-file --worker-tls-cert "
                     "--worker-tls-key --worker-tls-ca --worker-tls-server-name --leaf-deadline --leaf-threads --result-ttl")
WORKER_FLAGS = ("--listen --advertise --coordinator --threads --cluster-token-file --tls-cert --tls-key "
                "--tls-ca --allow-insecure --drain-timeout --log-level")

K = "deploy/k8s/base/"
MUTATIONS = [  # (what, file, old, new)
    ("probe on an undeclared port", K + "worker-deployment.yaml", "grpc:\n              port: 7413",
     "grpc:\n              port: 7414"),
    ("Service targetPort without a container port", K + "coordinator-services.yaml",
     "targetPort: grpc-workers", "targetPort: grpc-worker"),
    ("unknown flag in an env file", "deploy/systemd/worker.env.example", "--coordinator=", "--coordinater="),
    ("unknown flag in Kubernetes args", "deploy/k8s/overlays/example/coordinator-tls.yaml",
     "--leaf-deadline=300", "--leaf-dedline=300"),
    ("unknown flag in up.sh", "deploy/local/up.sh", "--worker-listen 127.0.0.1:0", "--workers-listen 127.0.0.1:0"),
    ("grace period below the drain timeout", K + "worker-deployment.yaml",
     "terminationGracePeriodSeconds: 75", "terminationGracePeriodSeconds: 50"),
    ("hardening option missing", "deploy/systemd/pdrmesh-coordinator.service", "ProtectSystem=strict\n", ""),
    ("TimeoutStopSec below the drain timeout", "deploy/systemd/pdrmesh-worker@.service",
     "TimeoutStopSec=75", "TimeoutStopSec=45"),
    ("Secret key that does not exist", "deploy/k8s/overlays/example/worker-tls.yaml",
     "- key: worker.key", "- key: worker.pem"),
    ("--coordinator not a Service port", K + "worker-deployment.yaml",
     "pdrmesh-coordinator-workers:7412", "pdrmesh-coordinator-workers:7499"),
    ("writable root filesystem", K + "coordinator-statefulset.yaml",
     "readOnlyRootFilesystem: true", "readOnlyRootFilesystem: false"),
    ("YAML syntax error", K + "worker-hpa.yaml", "  minReplicas: 2", "  minReplicas: [2"),
]
if shutil.which("systemd-analyze"):
    MUTATIONS.append(("unknown systemd key", "deploy/systemd/pdrmesh-worker@.service",
                      "LockPersonality=yes", "LockPersonality=yes\nLockPersonalty=yes"))


def run(root, tmp, label, mutation):
    work = os.path.join(tmp, label)
    shutil.copytree(os.path.join(root, "deploy"), os.path.join(work, "deploy"), symlinks=True)
    if mutation:
        _, rel, old, new = mutation
        path = os.path.join(work, rel)
        with open(path, encoding="utf-8") as f:
            text = f.read()
        if old not in text:
            return False, f"the text to change is not in {rel}: {old!r}"
        with open(path, "w", encoding="utf-8") as f:
            f.write(text.replace(old, new, 1))
    r = subprocess.run([sys.executable, os.path.join(HERE, "check_deploy.py"), "--root", work,
                        "--coordinator", os.path.join(tmp, "bin", "pdrmesh-coordinator"),
                        "--worker", os.path.join(tmp, "bin", "pdrmesh-worker"), "--kubectl", ""],
                       capture_output=True, text=True, timeout=60)
    fails = [ln for ln in r.stdout.splitlines() if ln.startswith("FAIL")]
    return r.returncode, fails or [r.stdout[-400:] + r.stderr[-400:]]


def main():
    root = sys.argv[1]
    with tempfile.TemporaryDirectory() as tmp:
        os.makedirs(os.path.join(tmp, "bin"))
        for name, flags in (("pdrmesh-coordinator", COORDINATOR_FLAGS), ("pdrmesh-worker", WORKER_FLAGS)):
            path = os.path.join(tmp, "bin", name)
            with open(path, "w", encoding="utf-8") as f:
                f.write(f"#!/bin/sh\necho 'Options: -h,--help {flags}'\n")
            os.chmod(path, 0o755)
        jobs = [("unchanged", None)] + [(f"m{i}", m) for i, m in enumerate(MUTATIONS)]
        with concurrent.futures.ThreadPoolExecutor(max_workers=4) as pool:
            results = list(pool.map(lambda j: run(root, tmp, *j), jobs))
    passed = failed = 0
    for (label, m), (rc, fails) in zip(jobs, results):
        if m is None:
            good = rc == 0
            what = "the unchanged deploy/ passes"
        else:
            good = rc == 1
            what = f"caught: {m[0]}"
        print(("ok: " if good else "FAIL: ") + what + ("" if good and m is None else f" ({fails[0]})"))
        passed, failed = passed + good, failed + (not good)
    print(f"{passed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
