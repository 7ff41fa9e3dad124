#!/usr/bin/env python3
"""Checks every manifest under deploy/ offline, with no cluster.

- Agones kinds (GameServer, Fleet, FleetAutoscaler) against the
  openAPIV3Schema of Agones's CRDs (deploy/schemas/, extracted from
  ../shared/agones/crds.yaml by --refresh-schemas), strictly: a field the
  schema does not have is an error, as kubectl's server-side validation
  would say.
- Core kinds (Deployment, Service, PersistentVolumeClaim, and the pod
  template inside every GameServer spec) with kubernetes-validate, strict.
- The Kustomize overlays, rendered first (see render_kustomization for the
  subset of Kustomize they may use).
- The project's own invariants: a server listening beyond loopback is
  given its key and certificate (dev mode would refuse to start); the game
  port is UDP everywhere; container
  ports equal the ports in the server's --listen and --metrics flags;
  probes on /readyz and /healthz at the metrics port;
  terminationGracePeriodSeconds (and compose's stop_grace_period) longer
  than the server's drain; resource requests at least what the committed
  `inertia-bench capacity` results measure for --max-clients clients;
  the single GameServer's spec equal to the fleet's template; every metric
  the Prometheus alerts name is one the server registers.

Exit status 0 when everything passes; 1 with one line per problem.
Needs: pyyaml, jsonschema, kubernetes-validate (pip).
"""

import argparse
import copy
import gzip
import json
import os
import re
import sys

import jsonschema
import kubernetes_validate
import yaml

DEPLOY = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(DEPLOY)
SCHEMAS = os.path.join(DEPLOY, "schemas", "agones-v1.schemas.json.gz")
SHARED_CRDS = os.path.join(ROOT, "..", "shared", "agones", "crds.yaml")
KUBERNETES_VERSION = "1.33"
GAME_PORT_NAME = "game"
# Drain: SHUTDOWN_DEADLINE (server/src/server.rs) plus EXIT_GRACE
# (server/src/process.rs), read from the source so they stay true.
SERVER_RS = os.path.join(ROOT, "server", "src", "server.rs")
PROCESS_RS = os.path.join(ROOT, "server", "src", "process.rs")
CONFIG_RS = os.path.join(ROOT, "server", "src", "config.rs")
BENCH_RESULTS = os.path.join(ROOT, "bench", "results")
# Requests must cover the measured need this many times over.
HEADROOM = 1.5

AGONES_KINDS = {
    ("agones.dev/v1", "GameServer"),
    ("agones.dev/v1", "Fleet"),
    ("agones.dev/v1", "GameServerSet"),
    ("autoscaling.agones.dev/v1", "FleetAutoscaler"),
}

problems = []


def problem(where, what):
    problems.append(f"{where}: {what}")


# ---------------------------------------------------------------- schemas


def extract_schemas(crds_path):
    """Each CRD version's openAPIV3Schema, by `group/version/Kind`."""
    out = {}
    with open(crds_path) as f:
        for doc in yaml.safe_load_all(f):
            if not doc or doc.get("kind") != "CustomResourceDefinition":
                continue
            spec = doc["spec"]
            for v in spec["versions"]:
                key = f"{spec['group']}/{v['name']}/{spec['names']['kind']}"
                out[key] = v["schema"]["openAPIV3Schema"]
    return out


def load_schemas():
    with gzip.open(SCHEMAS, "rt") as f:
        schemas = json.load(f)
    if os.path.exists(SHARED_CRDS) and extract_schemas(SHARED_CRDS) != schemas:
        problem(SCHEMAS, "differs from ../shared/agones/crds.yaml: run --refresh-schemas")
    return schemas


def unknown_fields(doc, schema, path):
    """Fields of `doc` the structural schema does not declare."""
    if not isinstance(schema, dict) or schema.get("x-kubernetes-preserve-unknown-fields"):
        return
    if isinstance(doc, dict):
        props = schema.get("properties")
        extra = schema.get("additionalProperties")
        for k, v in doc.items():
            if props is not None and k in props:
                yield from unknown_fields(v, props[k], f"{path}.{k}")
            elif isinstance(extra, dict):
                yield from unknown_fields(v, extra, f"{path}.{k}")
            elif props is not None or extra is False:
                yield f"{path}.{k}"
    elif isinstance(doc, list) and isinstance(schema.get("items"), dict):
        for i, v in enumerate(doc):
            yield from unknown_fields(v, schema["items"], f"{path}[{i}]")


def check_agones(where, doc, schemas):
    api, kind = doc["apiVersion"], doc["kind"]
    schema = schemas.get(f"{api}/{kind}")
    if schema is None:
        problem(where, f"no schema for {api} {kind}")
        return
    validator = jsonschema.Draft7Validator(schema)
    for e in validator.iter_errors(doc):
        loc = ".".join(str(p) for p in e.absolute_path) or "."
        problem(where, f"{kind} {loc}: {e.message}")
    # apiVersion, kind and metadata are every object's, not the CRD's.
    body = {k: v for k, v in doc.items() if k not in ("apiVersion", "kind", "metadata")}
    for field in unknown_fields(body, schema, kind):
        problem(where, f"unknown field {field}")
    # The pod template is opaque to the CRD: validate it as a Pod.
    spec = doc.get("spec", {})
    gs_spec = spec.get("template", {}).get("spec", {}) if kind in ("Fleet", "GameServerSet") else spec
    if kind != "FleetAutoscaler":
        template = gs_spec.get("template", {})
        pod = {
            "apiVersion": "v1",
            "kind": "Pod",
            "metadata": template.get("metadata", {}) or {"name": "template"},
            "spec": template.get("spec", {}),
        }
        pod["metadata"].setdefault("name", "template")
        check_core(f"{where} ({kind} pod template)", pod)


def check_core(where, doc):
    try:
        kubernetes_validate.validate(doc, KUBERNETES_VERSION, strict=True)
    except kubernetes_validate.ValidationError as e:
        loc = ".".join(str(p) for p in e.path) or "."
        problem(where, f"{doc.get('kind')} {loc}: {e.message}")
    except kubernetes_validate.SchemaNotFoundError as e:
        problem(where, f"no schema: {e}")


# ---------------------------------------------------------------- kustomize

KUSTOMIZE_KEYS = {"apiVersion", "kind", "resources", "namespace", "labels", "images", "patches"}


def merge(base, patch):
    """Strategic-merge-like: maps merge key by key, lists of maps merge by
    `name`, anything else is replaced."""
    if isinstance(base, dict) and isinstance(patch, dict):
        out = dict(base)
        for k, v in patch.items():
            out[k] = merge(base[k], v) if k in base else copy.deepcopy(v)
        return out
    if (
        isinstance(base, list)
        and isinstance(patch, list)
        and all(isinstance(x, dict) and "name" in x for x in base + patch)
    ):
        out = [copy.deepcopy(x) for x in base]
        for p in patch:
            at = next((i for i, x in enumerate(out) if x["name"] == p["name"]), None)
            if at is None:
                out.append(copy.deepcopy(p))
            else:
                out[at] = merge(out[at], p)
        return out
    return copy.deepcopy(patch)


def containers_of(doc):
    """Every container list in a resource (pod templates wherever they are)."""
    spec = doc.get("spec", {})
    for path in (
        ("template", "spec", "template", "spec"),  # Fleet, GameServerSet
        ("template", "spec"),  # Deployment; GameServer's own template
    ):
        node = spec
        for p in path:
            node = node.get(p, {}) if isinstance(node, dict) else {}
        if isinstance(node, dict) and "containers" in node:
            yield node
            return


def render_kustomization(directory, raw=False):
    """The resources a kustomization makes. Supported: resources (files or
    directories with a kustomization.yaml), namespace, labels (pairs, added
    to metadata.labels), images (name → newName/newTag) and patches (files
    with a partial resource, matched by kind and name, merged as `merge`
    does). Anything else is refused rather than rendered wrong."""
    path = os.path.join(directory, "kustomization.yaml")
    with open(path) as f:
        k = yaml.safe_load(f)
    for key in set(k) - KUSTOMIZE_KEYS:
        problem(path, f"kustomization key {key!r} is not one this renderer supports")
    out = []
    for r in k.get("resources", []):
        full = os.path.normpath(os.path.join(directory, r))
        if os.path.isdir(full):
            out += render_kustomization(full, raw=True)
        elif os.path.dirname(full) != directory and not full.startswith(directory + os.sep):
            problem(path, f"{r}: a file outside the kustomization (kustomize refuses it)")
        else:
            with open(full) as f:
                out += [(full, d) for d in yaml.safe_load_all(f) if d]
    for p in k.get("patches", []):
        pfile = os.path.join(directory, p["path"])
        with open(pfile) as f:
            patch = yaml.safe_load(f)
        matched = [
            i
            for i, (_, d) in enumerate(out)
            if d["kind"] == patch["kind"] and d["metadata"].get("name") == patch["metadata"]["name"]
        ]
        if len(matched) != 1:
            problem(pfile, f"matches {len(matched)} resources, not one")
            continue
        i = matched[0]
        out[i] = (out[i][0], merge(out[i][1], patch))
    rendered = []
    for src, d in out:
        d = copy.deepcopy(d)
        if "namespace" in k:
            d["metadata"]["namespace"] = k["namespace"]
        for group in k.get("labels", []):
            d["metadata"].setdefault("labels", {}).update(group["pairs"])
        for image in k.get("images", []):
            for pod in containers_of(d):
                for c in pod["containers"]:
                    name, _, tag = c["image"].rpartition(":")
                    if name == image["name"]:
                        c["image"] = f"{image.get('newName', name)}:{image.get('newTag', tag)}"
        rendered.append((src, d))
    if raw:
        return rendered
    return [(f"{os.path.relpath(path, ROOT)} ({os.path.relpath(src, ROOT)})", d) for src, d in rendered]


# ---------------------------------------------------------------- invariants


def rust_secs(path, name):
    with open(path) as f:
        m = re.search(rf"{name}: [^=]*= [^;]*from_secs\((\d+)\)", f.read())
    if not m:
        problem(path, f"cannot find {name}")
        return 0
    return int(m.group(1))


def rust_const(path, name):
    with open(path) as f:
        m = re.search(rf"pub const {name}: \w+ = (\d+);", f.read())
    return int(m.group(1)) if m else None


def default_seek_memory_mb():
    """The server's default --seek-memory-mb (DEFAULT_SEEK_MEMORY_MB, 1 GiB)."""
    return 1024


def drain_seconds():
    return rust_secs(SERVER_RS, "SHUTDOWN_DEADLINE") + rust_secs(PROCESS_RS, "EXIT_GRACE")


def flag(args, name):
    for i, a in enumerate(args):
        if a == name and i + 1 < len(args):
            return args[i + 1]
        if a.startswith(name + "="):
            return a.split("=", 1)[1]
    return None


def port_of(addr):
    return int(addr.rsplit(":", 1)[1]) if addr else None


def capacity_need(max_clients):
    """(cores, MiB) the newest committed capacity run measures for
    `max_clients` clients: idle plus per-client cost."""
    best = None
    for name in sorted(os.listdir(BENCH_RESULTS)):
        if not name.endswith(".jsonl"):
            continue
        with open(os.path.join(BENCH_RESULTS, name)) as f:
            for line in f:
                r = json.loads(line)
                if r.get("suite") == "capacity" and "rss_kb_per_client" in r and r.get("clients", 0) >= 50:
                    best = r
    if best is None:
        problem(BENCH_RESULTS, "no capacity results to size the requests from")
        return 0, 0
    k = best["clients"]
    per_client_cores = (best["server_cpu_percent"] - best["server_idle_cpu_percent"]) / 100 / k
    idle_mb = best["rss_mb"] - best["rss_kb_per_client"] * k / 1024
    cores = best["server_idle_cpu_percent"] / 100 + per_client_cores * max_clients
    mib = idle_mb + best["rss_kb_per_client"] * max_clients / 1024
    return cores, mib


def quantity(q):
    """A CPU (cores) or memory (MiB) quantity."""
    q = str(q)
    units = {"m": 1e-3, "Ki": 1 / 1024, "Mi": 1, "Gi": 1024}
    for u, f in units.items():
        if q.endswith(u):
            return float(q[: -len(u)]) * f
    return float(q)


def refuses_dev_mode(where, args, env):
    """The server runs in dev mode without a key and certificate, and dev
    mode refuses to listen beyond loopback: such a manifest never starts."""
    listen = flag(args, "--listen") or ""
    if listen.startswith(("127.", "[::1]", "localhost")):
        return
    for name in ("key-file", "cert-file", "cert-key-file"):
        var = "INERTIA_" + name.upper().replace("-", "_")
        if flag(args, "--" + name) is None and var not in env:
            problem(where, f"--listen {listen} needs --{name} (or {var}): dev mode listens on loopback only")


def check_pod(where, pod, game_port_from_agones=None):
    drain = drain_seconds()
    grace = pod.get("terminationGracePeriodSeconds", 30)
    if grace <= drain:
        problem(where, f"terminationGracePeriodSeconds {grace} is not longer than the drain ({drain} s)")
    servers = [c for c in pod["containers"] if c["name"] == "inertia-server"]
    if len(servers) != 1:
        problem(where, "no container named inertia-server")
        return
    c = servers[0]
    args = c.get("args", [])
    listen, metrics = port_of(flag(args, "--listen")), port_of(flag(args, "--metrics"))
    if listen is None or metrics is None:
        problem(where, "the server's --listen and --metrics must be given (ports the manifest publishes)")
        return
    refuses_dev_mode(where, args, {e["name"]: e.get("value") for e in c.get("env", [])})
    ports = {p["containerPort"]: p for p in c.get("ports", [])}
    if game_port_from_agones is not None:
        if game_port_from_agones != listen:
            problem(where, f"Agones game containerPort {game_port_from_agones} != --listen port {listen}")
    elif listen not in ports or ports[listen].get("protocol") != "UDP":
        problem(where, f"the game port {listen} must be a UDP container port")
    if metrics not in ports or ports[metrics].get("protocol", "TCP") != "TCP":
        problem(where, f"the metrics port {metrics} must be a TCP container port")
    for probe, path in (("readinessProbe", "/readyz"), ("livenessProbe", "/healthz")):
        get = c.get(probe, {}).get("httpGet", {})
        if get.get("path") != path or get.get("port") != metrics:
            problem(where, f"{probe} must GET {path} on the metrics port {metrics}")
    max_clients = int(flag(args, "--max-clients") or rust_const(CONFIG_RS, "DEFAULT_MAX_CLIENTS") or 64)
    cores, mib = capacity_need(max_clients)
    req = c.get("resources", {}).get("requests", {})
    if "cpu" not in req or quantity(req["cpu"]) < HEADROOM * cores:
        problem(where, f"cpu request must be ≥ {HEADROOM} × {cores:.2f} cores measured for {max_clients} clients")
    if "memory" not in req or quantity(req["memory"]) < HEADROOM * mib:
        problem(where, f"memory request must be ≥ {HEADROOM} × {mib:.0f} MiB measured for {max_clients} clients")
    # Seeking holds up to --seek-memory-mb on top, in a long match.
    seek = int(flag(args, "--seek-memory-mb") or default_seek_memory_mb())
    limit = c.get("resources", {}).get("limits", {}).get("memory")
    if limit is None or quantity(limit) < HEADROOM * mib + seek:
        problem(where, f"memory limit must be ≥ {HEADROOM} × {mib:.0f} MiB + --seek-memory-mb {seek}")


def check_invariants(where, doc):
    kind = doc["kind"]
    if kind in ("GameServer", "Fleet", "GameServerSet"):
        gs = doc["spec"]["template"]["spec"] if kind != "GameServer" else doc["spec"]
        game = [p for p in gs.get("ports", []) if p.get("name") == GAME_PORT_NAME]
        if len(game) != 1 or game[0].get("protocol") != "UDP":
            problem(where, "the Agones port `game` must be one UDP port")
            return
        check_pod(where, gs["template"]["spec"], game[0].get("containerPort"))
    elif kind == "Deployment":
        check_pod(where, doc["spec"]["template"]["spec"])
    elif kind == "Service":
        for p in doc["spec"]["ports"]:
            if p.get("name") == GAME_PORT_NAME and p.get("protocol") != "UDP":
                problem(where, "the game Service port must be UDP")


def check_compose(path):
    with open(path) as f:
        c = yaml.safe_load(f)
    s = c["services"]["inertia-server"]
    cmd = s["command"]
    listen, metrics = port_of(flag(cmd, "--listen")), port_of(flag(cmd, "--metrics"))
    refuses_dev_mode(path, cmd, s.get("environment", {}))
    ports = s.get("ports", [])
    if not any(p.endswith(f":{listen}/udp") for p in ports):
        problem(path, f"the game port {listen} must be published as UDP")
    if not any(p.endswith(f":{metrics}/tcp") or p.endswith(f":{metrics}") for p in ports):
        problem(path, f"the metrics port {metrics} must be published")
    grace = s.get("stop_grace_period", "10s")
    if int(grace.rstrip("s")) <= drain_seconds():
        problem(path, f"stop_grace_period {grace} is not longer than the drain ({drain_seconds()} s)")


def check_alerts(path):
    """Every metric an alert names is one the server registers."""
    with open(os.path.join(ROOT, "server", "src", "metrics.rs")) as f:
        source = f.read()
    registered = set(re.findall(r'register\(\s*"([a-z_]+)"', source))
    with open(path) as f:
        text = f.read()
    for name in sorted(set(re.findall(r"\binertia_([a-z_]+)", text))):
        base = re.sub(r"_(total|bucket|sum|count)$", "", name)
        if base not in registered:
            problem(path, f"inertia_{name}: the server has no metric {base!r}")


# ---------------------------------------------------------------- main


def check(where, doc, schemas):
    key = (doc.get("apiVersion"), doc.get("kind"))
    if key in AGONES_KINDS:
        check_agones(where, doc, schemas)
    else:
        check_core(where, doc)
    check_invariants(where, doc)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--refresh-schemas", action="store_true", help="extract deploy/schemas from ../shared/agones/crds.yaml")
    opts = parser.parse_args()
    if opts.refresh_schemas:
        schemas = extract_schemas(SHARED_CRDS)
        os.makedirs(os.path.dirname(SCHEMAS), exist_ok=True)
        data = json.dumps(schemas, sort_keys=True, separators=(",", ":")).encode()
        with open(SCHEMAS, "wb") as f:
            f.write(gzip.compress(data, 9, mtime=0))
        print(f"wrote {os.path.relpath(SCHEMAS, ROOT)}: {', '.join(sorted(schemas))}")
        return 0
    schemas = load_schemas()
    checked = 0
    # Every plain manifest file.
    for d, _, files in sorted(os.walk(DEPLOY)):
        if os.sep + "overlays" in d or d.endswith(("schemas", "prometheus")):
            continue
        for name in sorted(files):
            if not name.endswith(".yaml") or name in ("kustomization.yaml", "compose.yaml"):
                continue
            path = os.path.join(d, name)
            with open(path) as f:
                for doc in yaml.safe_load_all(f):
                    if doc:
                        check(os.path.relpath(path, ROOT), doc, schemas)
                        checked += 1
    # The base and the overlays, rendered.
    for k in ("agones", "overlays/dev", "overlays/prod"):
        for where, doc in render_kustomization(os.path.join(DEPLOY, k)):
            check(where, doc, schemas)
            checked += 1
    check_compose(os.path.join(DEPLOY, "compose.yaml"))
    check_alerts(os.path.join(DEPLOY, "prometheus", "alerts.yaml"))
    checked += 2
    # The single GameServer is the fleet's template.
    with open(os.path.join(DEPLOY, "agones", "gameserver.yaml")) as f:
        gs = yaml.safe_load(f)
    with open(os.path.join(DEPLOY, "agones", "fleet.yaml")) as f:
        fleet = yaml.safe_load(f)
    if gs["spec"] != fleet["spec"]["template"]["spec"]:
        problem("deploy/agones/gameserver.yaml", "spec differs from the fleet's template spec")
    for p in problems:
        print(p)
    if problems:
        print(f"deploy/validate.py: {len(problems)} problems in {checked} manifests")
        return 1
    print(f"deploy/validate.py: {checked} manifests valid (Kubernetes {KUBERNETES_VERSION}, Agones CRDs)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
