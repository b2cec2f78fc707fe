"""Checks a Kubernetes Job manifest (JSON) against the Job schema as the
official Kubernetes Python client declares it: every field of every object
must be one its model declares (by its JSON name), of the declared type,
and the client must build the model from it (its required fields present,
its enumerations' values allowed). Then the Indexed Job contract that
`sensor-replay campaign run-chunk` relies on.

Usage: check_k8s_job.py JOB.json   (exit 0 and "ok" when it holds)
"""

import json
import re
import sys

import kubernetes.client as k8s
from kubernetes.client import ApiClient

PRIMITIVES = {"str": str, "int": int, "bool": bool, "float": (int, float), "object": object}


def check(value, type_name, path, errors):
    m = re.fullmatch(r"[Ll]ist\[(.+)\]", type_name)
    if m:
        if not isinstance(value, list):
            errors.append(f"{path}: expected a list, got {type(value).__name__}")
            return
        for i, v in enumerate(value):
            check(v, m.group(1), f"{path}[{i}]", errors)
        return
    m = re.fullmatch(r"(?:dict\((\w+), (.+)\)|Dict\[(\w+), (.+)\])", type_name)
    if m:
        if not isinstance(value, dict):
            errors.append(f"{path}: expected a map, got {type(value).__name__}")
            return
        for k, v in value.items():
            check(v, m.group(2) or m.group(4), f"{path}.{k}", errors)
        return
    if type_name in PRIMITIVES:
        t = PRIMITIVES[type_name]
        if t is int and isinstance(value, bool) or not isinstance(value, t):
            errors.append(f"{path}: expected {type_name}, got {type(value).__name__} {value!r}")
        return
    model = getattr(k8s, type_name, None)
    if model is None:
        errors.append(f"{path}: the client has no model {type_name}")
        return
    if not isinstance(value, dict):
        errors.append(f"{path}: expected an object {type_name}, got {type(value).__name__}")
        return
    json_to_attr = {j: a for a, j in model.attribute_map.items()}
    for key, v in value.items():
        attr = json_to_attr.get(key)
        if attr is None:
            errors.append(f"{path}.{key}: not a field of {type_name}")
            continue
        check(v, model.openapi_types[attr], f"{path}.{key}", errors)


def main():
    job = json.load(open(sys.argv[1]))
    errors = []
    check(job, "V1Job", "Job", errors)
    # The client builds the model: required fields and enumerations checked.
    try:
        ApiClient()._ApiClient__deserialize(job, "V1Job")
    except (ValueError, TypeError) as e:
        errors.append(f"the client refuses the Job: {e}")
    spec = job.get("spec", {})
    pod = spec.get("template", {}).get("spec", {})
    need = [
        (job.get("apiVersion") == "batch/v1", "apiVersion is batch/v1"),
        (job.get("kind") == "Job", "kind is Job"),
        (spec.get("completionMode") == "Indexed", "completionMode is Indexed (JOB_COMPLETION_INDEX set in each pod)"),
        (isinstance(spec.get("completions"), int) and spec["completions"] >= 1, "completions >= 1"),
        (1 <= spec.get("parallelism", 0) <= spec.get("completions", 0), "1 <= parallelism <= completions"),
        (pod.get("restartPolicy") in ("Never", "OnFailure"), "restartPolicy Never or OnFailure"),
        (len(pod.get("containers", [])) == 1, "one container"),
    ]
    for ok, what in need:
        if not ok:
            errors.append(f"Indexed Job contract: {what}")
    cmd = (pod.get("containers") or [{}])[0].get("command", [])
    if cmd[:3] != ["sensor-replay", "campaign", "run-chunk"] or "--chunk" not in cmd:
        errors.append(f"the container does not run `sensor-replay campaign run-chunk DIR --chunk K`: {cmd}")
    if errors:
        print("\n".join(errors))
        sys.exit(1)
    print("ok")


main()
