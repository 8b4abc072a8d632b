#!/usr/bin/python3
# SPDX-License-Identifier: AGPL-3.0-or-later
# Offline check of deploy/: every YAML parses; the kustomizations build (`kubectl kustomize`,
# skipped without kubectl; a small strategic merge of the overlay patches stands in); in what they
# build, every port a probe, Service, NetworkPolicy or flag names exists, Secrets and volumes
# referenced exist, the pods are locked down; systemd units carry their hardening and pass
# `systemd-analyze verify` (skipped without it); and every --flag given to pdrmesh-coordinator or
# pdrmesh-worker (Kubernetes args, ExecStart, env files, deploy/local/up.sh) is in that binary's
# --help. A binary not in the build is skipped with a message; once both are built, a flag
# missing from --help fails.
# Usage: check_deploy.py --root REPO --coordinator BIN [--worker BIN] [--kubectl PATH]
# Debian's python3 with python3-yaml (scripts/install-deps.sh).
import argparse
import configparser
import copy
import os
import re
import shutil
import subprocess
import sys
import tempfile

try:
    import yaml
except ImportError:
    print("FAIL: python3-yaml is missing (scripts/install-deps.sh installs it)")
    print("0 passed, 1 failed")
    sys.exit(1)

FLAG = re.compile(r"(?<![\w-])--[a-z][a-z0-9]*(?:-[a-z0-9]+)*")
BINARIES = ("pdrmesh-coordinator", "pdrmesh-worker")
WORKLOADS = ("Deployment", "StatefulSet", "DaemonSet", "Job")
HARDENING = {  # systemd key: the value it must have (None: present, any value)
    "User": None, "NoNewPrivileges": "yes", "ProtectSystem": "strict", "ProtectHome": "yes",
    "PrivateTmp": "yes", "CapabilityBoundingSet": "", "MemoryDenyWriteExecute": "yes",
    "RestrictAddressFamilies": "AF_INET AF_INET6 AF_UNIX", "SystemCallFilter": "@system-service",
    "LimitNOFILE": None, "Restart": "on-failure", "KillSignal": "SIGTERM", "TimeoutStopSec": None,
    "EnvironmentFile": None,
}


class Checker:
    def __init__(self):
        self.passed = 0
        self.failed = 0

    def ok(self, cond, what, detail=""):
        if cond:
            self.passed += 1
            print(f"ok: {what}")
        else:
            self.failed += 1
            print(f"FAIL: {what}" + (f": {detail}" if detail else ""))
        return cond

    @staticmethod
    def skip(what):
        print(f"SKIP: {what}")

    @staticmethod
    def note(what):
        print(f"NOTE: {what}")


# --- flags -----------------------------------------------------------------------------------

class Flags:
    """--help of each daemon; `strict` once both are built."""

    def __init__(self, c, paths):
        self.c = c
        self.help = {}
        for name, path in paths.items():
            if not path:
                c.skip(f"{name} is not a target of this build: its flags are not checked")
                continue
            if not os.access(path, os.X_OK):
                c.ok(False, f"{name} is a target but not built", path)
                continue
            r = subprocess.run([path, "--help"], capture_output=True, text=True, timeout=10)
            text = r.stdout + r.stderr
            c.ok(r.returncode == 0 and "--help" in text, f"{name} --help runs", text[-300:])
            self.help[name] = set(FLAG.findall(text))
        self.strict = all(b in self.help for b in BINARIES)
        if not self.strict and self.help:
            c.note("not both daemons are built: a flag missing from the --help of the one that is "
                   "is reported, not failed (flags.md's new flags are being written); with both "
                   "built it fails")

    def check(self, binary, flags, where):
        if binary not in self.help:
            self.c.skip(f"{where}: {binary} not built, flags {' '.join(sorted(set(flags)))} unchecked")
            return
        missing = sorted(set(flags) - self.help[binary])
        if missing and not self.strict:
            self.c.note(f"{where}: {binary} --help lacks {' '.join(missing)} (not failing: "
                        "pdrmesh-worker is not built yet)")
            return
        self.c.ok(not missing, f"{where}: {len(set(flags))} flags of {binary} are in its --help",
                  "missing " + " ".join(missing))


# --- YAML and kustomize ----------------------------------------------------------------------

def load_all(path):
    with open(path, encoding="utf-8") as f:
        return [d for d in yaml.safe_load_all(f) if d is not None]


MERGE_KEYS = {"containers": "name", "initContainers": "name", "volumes": "name", "env": "name",
              "ports": "containerPort", "volumeMounts": "mountPath"}


def merge(base, patch, key=None):
    """The part of Kubernetes' strategic merge these manifests use: maps merge, null deletes,
    lists of objects with a merge key merge by it, other lists are replaced."""
    if isinstance(base, dict) and isinstance(patch, dict):
        out = dict(base)
        for k, v in patch.items():
            if v is None:
                out.pop(k, None)
            elif k in out:
                out[k] = merge(out[k], v, k)
            else:
                out[k] = copy.deepcopy(v)
        return out
    if isinstance(base, list) and isinstance(patch, list) and key in MERGE_KEYS:
        mk = MERGE_KEYS[key]
        out = [copy.deepcopy(x) for x in base]
        for item in patch:
            match = [i for i, x in enumerate(out) if isinstance(x, dict) and x.get(mk) == item.get(mk)]
            if match:
                out[match[0]] = merge(out[match[0]], item, None)
            else:
                out.append(copy.deepcopy(item))
        return out
    return copy.deepcopy(patch)


def build_without_kubectl(kdir):
    """resources, patches and generated Secret names (without hash suffixes) of a kustomization."""
    k = load_all(os.path.join(kdir, "kustomization.yaml"))[0]
    objs = []
    for res in k.get("resources", []):
        p = os.path.join(kdir, res)
        objs += build_without_kubectl(p) if os.path.isdir(p) else load_all(p)
    for gen in k.get("secretGenerator", []):
        data = {}
        for f in gen.get("files", []):
            name, _, path = f.partition("=") if "=" in f else (os.path.basename(f), "", f)
            data[name] = path
        objs.append({"apiVersion": "v1", "kind": "Secret", "metadata": {"name": gen["name"]},
                     "type": gen.get("type", "Opaque"), "data": data})
    for p in k.get("patches", []):
        for patch in load_all(os.path.join(kdir, p["path"])):
            for i, o in enumerate(objs):
                if o["kind"] == patch["kind"] and o["metadata"]["name"] == patch["metadata"]["name"]:
                    objs[i] = merge(o, patch)
    return objs


def build(c, kdir, kubectl, rel):
    if kubectl:
        r = subprocess.run([kubectl, "kustomize", kdir], capture_output=True, text=True, timeout=60)
        if not c.ok(r.returncode == 0, f"kubectl kustomize {rel}", r.stderr.strip()[-500:]):
            return None
        return [d for d in yaml.safe_load_all(r.stdout) if d is not None]
    return build_without_kubectl(kdir)


# --- Kubernetes checks -----------------------------------------------------------------------

def pod_spec(o):
    return o["spec"]["template"]["spec"]


def pod_labels(o):
    return o["spec"]["template"]["metadata"].get("labels", {})


def selects(selector, labels):
    return bool(selector) and all(labels.get(k) == v for k, v in selector.items())


def container_ports(spec):
    names, numbers = set(), set()
    for ctr in spec.get("containers", []):
        for p in ctr.get("ports", []):
            numbers.add(p["containerPort"])
            if "name" in p:
                names.add(p["name"])
    return names, numbers


def port_exists(port, names, numbers):
    return port in names if isinstance(port, str) else port in numbers


def check_workload(c, o, where, flags, by_kind, rendered_secrets):
    name = f"{where}: {o['kind']}/{o['metadata']['name']}"
    spec = pod_spec(o)
    psc = spec.get("securityContext", {})
    volumes = {v["name"]: v for v in spec.get("volumes", [])}
    claims = {t["metadata"]["name"] for t in o["spec"].get("volumeClaimTemplates", [])}
    c.ok(o["spec"]["selector"]["matchLabels"].items() <= pod_labels(o).items(),
         f"{name}: the selector matches the pod template's labels")
    for ctr in spec["containers"]:
        cname = f"{name} container {ctr['name']}"
        names, numbers = container_ports({"containers": [ctr]})
        for kind in ("startupProbe", "readinessProbe", "livenessProbe"):
            probe = ctr.get(kind)
            if probe is None:
                continue
            handlers = [h for h in ("grpc", "tcpSocket", "httpGet", "exec") if h in probe]
            if not c.ok(len(handlers) == 1, f"{cname} {kind} has one handler", str(handlers)):
                continue
            h = handlers[0]
            if h == "exec":
                continue
            port = probe[h]["port"]
            if h == "grpc":  # Kubernetes takes a number only here
                c.ok(isinstance(port, int) and port in numbers,
                     f"{cname} {kind} grpc port {port} is a declared containerPort", str(sorted(numbers)))
            else:
                c.ok(port_exists(port, names, numbers),
                     f"{cname} {kind} {h} port {port} is a declared port", f"{sorted(names)} {sorted(numbers)}")
        for probe_kind in ("readinessProbe", "livenessProbe"):
            c.ok(probe_kind in ctr, f"{cname} has a {probe_kind}")
        sc = ctr.get("securityContext", {})
        c.ok(sc.get("runAsNonRoot", psc.get("runAsNonRoot")) is True and
             sc.get("runAsUser", psc.get("runAsUser", 1)) != 0, f"{cname} runs as non-root")
        c.ok(sc.get("readOnlyRootFilesystem") is True, f"{cname} has a read-only root filesystem")
        c.ok(sc.get("allowPrivilegeEscalation") is False, f"{cname} forbids privilege escalation")
        c.ok(sc.get("privileged", False) is False, f"{cname} is not privileged")
        c.ok("ALL" in sc.get("capabilities", {}).get("drop", []), f"{cname} drops ALL capabilities")
        seccomp = sc.get("seccompProfile", psc.get("seccompProfile", {}))
        c.ok(seccomp.get("type") == "RuntimeDefault", f"{cname} uses the RuntimeDefault seccomp profile")
        res = ctr.get("resources", {})
        c.ok(all(r in res.get(k, {}) for k in ("requests", "limits") for r in ("cpu", "memory")),
             f"{cname} sets cpu and memory requests and limits")
        for m in ctr.get("volumeMounts", []):
            c.ok(m["name"] in volumes or m["name"] in claims,
                 f"{cname} mount {m['mountPath']} names a volume ({m['name']})")
        env = {e["name"] for e in ctr.get("env", [])}
        args = ctr.get("args", [])
        for ref in sorted({r for a in args for r in re.findall(r"\$\((\w+)\)", a)}):
            c.ok(ref in env, f"{cname} args use $({ref}), which its env defines")
        binary = os.path.basename((ctr.get("command") or [""])[0])
        if c.ok(binary in BINARIES, f"{cname} runs a pdrmesh daemon", str(ctr.get("command"))):
            flags.check(binary, [f for a in args for f in FLAG.findall(a.split("=", 1)[0])], cname)
        values = dict(a.split("=", 1) for a in args if a.startswith("--") and "=" in a)
        if "--drain-timeout" in values:
            grace = spec.get("terminationGracePeriodSeconds", 30)
            c.ok(grace > float(values["--drain-timeout"]),
                 f"{cname}: terminationGracePeriodSeconds {grace} exceeds --drain-timeout {values['--drain-timeout']}")
        if "--coordinator" in values:  # HOST:PORT of a Service here
            host, _, port = values["--coordinator"].rpartition(":")
            svc = by_kind.get(("Service", host))
            c.ok(svc is not None and int(port) in [p["port"] for p in svc["spec"]["ports"]],
                 f"{cname} --coordinator {values['--coordinator']} is a Service and one of its ports")
    for vname, v in volumes.items():
        if "secret" in v and rendered_secrets is not None:
            secret = by_kind.get(("Secret", v["secret"]["secretName"]))
            if c.ok(secret is not None, f"{name} volume {vname}: Secret {v['secret']['secretName']} exists"):
                keys = set(secret.get("data", {})) | set(secret.get("stringData", {}))
                for item in v["secret"].get("items", []):
                    c.ok(item["key"] in keys, f"{name} volume {vname}: key {item['key']} is in the Secret")


def check_objects(c, objs, where, flags, secrets_expected):
    by_kind = {(o["kind"], o["metadata"]["name"]): o for o in objs}
    workloads = [o for o in objs if o["kind"] in WORKLOADS]
    c.ok(all("namespace" not in o["metadata"] for o in objs), f"{where}: no object names a namespace")
    for o in workloads:
        check_workload(c, o, where, flags, by_kind, {} if secrets_expected else None)
    for o in objs:
        kind, oname = o["kind"], o["metadata"]["name"]
        if kind == "StatefulSet":
            c.ok(o["spec"].get("replicas") == 1, f"{where}: StatefulSet/{oname} has one replica")
            c.ok(("Service", o["spec"].get("serviceName")) in by_kind,
                 f"{where}: StatefulSet/{oname} serviceName is a Service")
            c.ok(bool(o["spec"].get("volumeClaimTemplates")), f"{where}: StatefulSet/{oname} claims a volume")
        if kind == "Service":
            pods = [w for w in workloads if selects(o["spec"].get("selector"), pod_labels(w))]
            if not c.ok(bool(pods), f"{where}: Service/{oname} selects a workload"):
                continue
            for p in o["spec"]["ports"]:
                target = p.get("targetPort", p["port"])
                for w in pods:
                    c.ok(port_exists(target, *container_ports(pod_spec(w))),
                         f"{where}: Service/{oname} targetPort {target} is a port of {w['metadata']['name']}")
        if kind == "NetworkPolicy":
            pods = [w for w in workloads if selects(o["spec"]["podSelector"].get("matchLabels"), pod_labels(w))]
            if not c.ok(bool(pods), f"{where}: NetworkPolicy/{oname} selects a workload"):
                continue
            for rule in o["spec"].get("ingress", []):
                for peer in rule.get("from", []):
                    if "podSelector" in peer:
                        c.ok(any(selects(peer["podSelector"].get("matchLabels"), pod_labels(w)) for w in workloads),
                             f"{where}: NetworkPolicy/{oname} lets in pods that exist")
                for p in rule.get("ports", []):
                    for w in pods:
                        c.ok(port_exists(p["port"], *container_ports(pod_spec(w))),
                             f"{where}: NetworkPolicy/{oname} port {p['port']} is a port of {w['metadata']['name']}")
        if kind == "HorizontalPodAutoscaler":
            ref = o["spec"]["scaleTargetRef"]
            target = by_kind.get((ref["kind"], ref["name"]))
            if c.ok(target is not None, f"{where}: HPA/{oname} scales an existing {ref['kind']}/{ref['name']}"):
                c.ok("replicas" not in target["spec"], f"{where}: {ref['kind']}/{ref['name']} leaves replicas to the HPA")
                cpu = any(m.get("resource", {}).get("name") == "cpu" for m in o["spec"].get("metrics", []))
                c.ok(cpu and all("cpu" in ctr.get("resources", {}).get("requests", {})
                                 for ctr in pod_spec(target)["containers"]),
                     f"{where}: HPA/{oname} scales on CPU and every container requests CPU")
    if secrets_expected:
        for o in objs:
            if o["kind"] == "Secret":
                c.ok(o.get("type") != "kubernetes.io/tls" or {"tls.crt", "tls.key"} <= set(o.get("data", {})),
                     f"{where}: Secret/{o['metadata']['name']} of type tls has tls.crt and tls.key")


def check_kubernetes(c, root, flags, kubectl):
    k8s = os.path.join(root, "deploy", "k8s")
    if not kubectl:
        c.skip("kubectl not found (not a Debian 12 package): `kubectl kustomize` not run; "
               "the kustomizations are assembled by this script's own strategic merge instead")
    dirs = sorted(d for d, _, files in os.walk(k8s) if "kustomization.yaml" in files)
    c.ok(os.path.join(k8s, "base") in dirs and any("/overlays/" in d for d in dirs),
         "deploy/k8s has a base and an overlay")
    for d in dirs:
        rel = os.path.relpath(d, root)
        objs = build(c, d, kubectl, rel)
        if objs is None:
            continue
        kinds = {o["kind"] for o in objs}
        c.ok({"StatefulSet", "Deployment", "HorizontalPodAutoscaler", "Service"} <= kinds,
             f"{rel} builds a StatefulSet, a Deployment, an HPA and Services", str(sorted(kinds)))
        overlay = "/overlays/" in d
        check_objects(c, objs, rel, flags, secrets_expected=overlay)
        if overlay:
            args = [a for o in objs if o["kind"] in WORKLOADS for ctr in pod_spec(o)["containers"]
                    for a in ctr.get("args", [])]
            c.ok("--allow-insecure" not in args and any(a.startswith("--worker-tls-ca=") for a in args)
                 and any(a.startswith("--tls-ca=") for a in args),
                 f"{rel}: mutual TLS between coordinator and workers, no --allow-insecure")


# --- systemd ---------------------------------------------------------------------------------

def parse_unit(path):
    """{section: {key: [values]}}; continuation lines joined."""
    out, section, pending = {}, None, ""
    with open(path, encoding="utf-8") as f:
        for raw in f:
            line = pending + raw.rstrip("\n")
            pending = ""
            if line.endswith("\\"):
                pending = line[:-1] + " "
                continue
            s = line.strip()
            if not s or s[0] in "#;":
                continue
            if s.startswith("["):
                section = s.strip("[]")
                out.setdefault(section, {})
            else:
                k, _, v = s.partition("=")
                out[section].setdefault(k.strip(), []).append(v.strip())
    return out


def env_file_flags(path):
    """Every --flag in an env file, its comments too (they show flags to uncomment)."""
    with open(path, encoding="utf-8") as f:
        return FLAG.findall(f.read())


def check_systemd(c, root, flags, paths):
    sdir = os.path.join(root, "deploy", "systemd")
    units = sorted(f for f in os.listdir(sdir) if f.endswith(".service"))
    c.ok({"pdrmesh-coordinator.service"} <= set(units) and any(u.startswith("pdrmesh-worker") for u in units),
         "deploy/systemd has a coordinator and a worker unit", str(units))
    analyze = shutil.which("systemd-analyze")
    if not analyze:
        c.skip("systemd-analyze not found: units not verified")
    for unit in units:
        u = parse_unit(os.path.join(sdir, unit))
        svc = u.get("Service", {})
        for key, want in HARDENING.items():
            have = svc.get(key)
            c.ok(have is not None and (want is None or want in have),
                 f"{unit}: {key}={'' if want is None else want}", f"has {have}")
        c.ok("yes" in svc.get("DynamicUser", []) or "User" in svc, f"{unit}: runs as its own user")
        exec_start = svc["ExecStart"][0]
        binary = os.path.basename(exec_start.split()[0])
        if not c.ok(binary in BINARIES, f"{unit}: ExecStart runs a pdrmesh daemon", exec_start):
            continue
        used = FLAG.findall(exec_start)
        for ef in svc.get("EnvironmentFile", []):
            example = os.path.join(sdir, os.path.basename(ef.lstrip("-")) + ".example")
            if c.ok(os.path.exists(example), f"{unit}: an example of {ef} is in deploy/systemd"):
                used += env_file_flags(example)
                with open(example, encoding="utf-8") as f:
                    defined = set(re.findall(r"^([A-Z_][A-Z0-9_]*)=", f.read(), re.M))
                for var in set(re.findall(r"\$\{?([A-Z_][A-Z0-9_]*)", exec_start)) - {"STATE_DIRECTORY"}:
                    c.ok(var in defined, f"{unit}: ${var} of ExecStart is set in {os.path.basename(example)}")
        flags.check(binary, used, unit)
        if binary == "pdrmesh-coordinator":
            c.ok("--data-dir=${STATE_DIRECTORY}" in exec_start and svc.get("StateDirectory"),
                 f"{unit}: --data-dir is the StateDirectory")
        m = re.search(r"--drain-timeout[= ](\d+)", exec_start)
        if m:
            stop = float(svc["TimeoutStopSec"][0].rstrip("s"))
            c.ok(stop > float(m.group(1)), f"{unit}: TimeoutStopSec {stop:g} exceeds --drain-timeout {m.group(1)}")
        if analyze:
            with tempfile.TemporaryDirectory() as tmp:
                target = paths.get(binary) if paths.get(binary) and os.path.exists(paths[binary]) else "/bin/true"
                with open(os.path.join(sdir, unit), encoding="utf-8") as f:
                    text = f.read().replace(f"/usr/local/bin/{binary}", target)
                with open(os.path.join(tmp, unit), "w", encoding="utf-8") as f:
                    f.write(text)
                name = unit.replace("@.service", "@7413.service")
                r = subprocess.run([analyze, "verify", os.path.join(tmp, name)], capture_output=True,
                                   text=True, timeout=30, cwd=tmp)
                msg = (r.stdout + r.stderr).strip()
                c.ok(r.returncode == 0 and not msg, f"{unit}: systemd-analyze verify is silent", msg[-800:])


# --- local scripts and image -----------------------------------------------------------------

def check_local(c, root, flags):
    path = os.path.join(root, "deploy", "local", "up.sh")
    with open(path, encoding="utf-8") as f:
        text = f.read().replace("\\\n", " ")
    for var, binary in (("coordinator_bin", "pdrmesh-coordinator"), ("worker_bin", "pdrmesh-worker")):
        lines = [ln for ln in text.splitlines() if re.search(rf'^\s*start \S+ "\${var}"', ln)]
        if c.ok(len(lines) == 1, f"deploy/local/up.sh starts {binary} once"):
            flags.check(binary, FLAG.findall(lines[0].split(f'"${var}"', 1)[1]), f"deploy/local/up.sh ({binary})")


def check_dockerfile(c, root):
    path = os.path.join(root, "deploy", "docker", "Dockerfile")
    with open(path, encoding="utf-8") as f:
        text = f.read()
    c.ok(re.search(r"^FROM debian:(12|bookworm)", text, re.M) is not None and text.count("\nFROM ") >= 1,
         "Dockerfile: multi-stage from Debian 12")
    users = re.findall(r"^USER\s+(\S+)", text, re.M)
    c.ok(bool(users) and users[-1].split(":")[0] not in ("root", "0"), "Dockerfile: runs as a non-root user")
    for binary in BINARIES:
        c.ok(binary in text, f"Dockerfile: installs {binary}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--root", required=True)
    ap.add_argument("--coordinator", default="")
    ap.add_argument("--worker", default="")
    ap.add_argument("--kubectl", default=shutil.which("kubectl") or "", help="'': as if absent")
    a = ap.parse_args()
    c = Checker()
    deploy = os.path.join(a.root, "deploy")
    n = 0
    for d, _, files in os.walk(deploy):
        for f in sorted(files):
            if f.endswith((".yaml", ".yml")):
                p = os.path.join(d, f)
                try:
                    load_all(p)
                    n += 1
                except yaml.YAMLError as e:
                    c.ok(False, f"{os.path.relpath(p, a.root)} parses", str(e))
    c.ok(n > 0, f"{n} YAML files under deploy/ parse")
    if c.failed:
        print(f"{c.passed} passed, {c.failed} failed (stopped: a YAML file does not parse)")
        return 1
    paths = {"pdrmesh-coordinator": a.coordinator, "pdrmesh-worker": a.worker}
    flags = Flags(c, paths)
    check_kubernetes(c, a.root, flags, a.kubectl)
    check_systemd(c, a.root, flags, paths)
    check_local(c, a.root, flags)
    check_dockerfile(c, a.root)
    print(f"{c.passed} passed, {c.failed} failed")
    return 1 if c.failed else 0


if __name__ == "__main__":
    sys.exit(main())
