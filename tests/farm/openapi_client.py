#!/usr/bin/env python3
"""A client of lensfarm's HTTP API written from its OpenAPI document alone (Python's urllib and json,
nothing of the project's): every operation is found by its operationId, every URL is built from
the document's paths and parameters, and every JSON answer is checked against the document's
schema for it. Run by tests/farm/http_api_test.cpp against a real coordinator and workers.

  openapi_client.py --base http://HOST:PORT --token-file F --document docs/api/openapi.json
                    --scene scene.json --asset meshes/cornell-box.obj=/path/to/file --out image.exr

Prints one line per check and exits 0 when all pass, 1 naming the first that failed.
"""
import argparse
import base64
import hashlib
import json
import re
import sys
import threading
import time
import urllib.error
import urllib.parse
import urllib.request


class Failure(Exception):
    pass


def check(condition, what):
    if not condition:
        raise Failure(what)
    print("ok:", what.split("\n")[0])


class Api:
    def __init__(self, base, token, document):
        self.base, self.token, self.doc = base.rstrip("/"), token, document
        self.ops = {}
        for path, item in document["paths"].items():
            for method, op in item.items():
                self.ops[op["operationId"]] = (method.upper(), path, op)

    # ---- schema checks (the subset of OpenAPI 3.0 the document uses) ----
    def resolve(self, schema):
        while "$ref" in schema:
            node = self.doc
            for part in schema["$ref"].lstrip("#/").split("/"):
                node = node[part]
            schema = node
        return schema

    def validate(self, schema, value, where):
        schema = self.resolve(schema)
        kind = schema.get("type")
        if kind == "object":
            if not isinstance(value, dict):
                raise Failure(f"{where}: expected an object, got {value!r}")
            props = schema.get("properties", {})
            for name in schema.get("required", []):
                if name not in value:
                    raise Failure(f"{where}: required field {name} missing")
            extra = schema.get("additionalProperties", True)
            for name, item in value.items():
                if name in props:
                    self.validate(props[name], item, f"{where}.{name}")
                elif extra is False:
                    raise Failure(f"{where}: field {name} is not in the document")
                elif isinstance(extra, dict):
                    self.validate(extra, item, f"{where}.{name}")
        elif kind == "array":
            if not isinstance(value, list):
                raise Failure(f"{where}: expected an array")
            for i, item in enumerate(value):
                self.validate(schema["items"], item, f"{where}[{i}]")
        elif kind == "string":
            if not isinstance(value, str):
                raise Failure(f"{where}: expected a string, got {value!r}")
            if "enum" in schema and value not in schema["enum"]:
                raise Failure(f"{where}: {value!r} is not one of {schema['enum']}")
            if "pattern" in schema and not re.search(schema["pattern"], value):
                raise Failure(f"{where}: {value!r} does not match {schema['pattern']}")
            if schema.get("format") == "byte":
                base64.b64decode(value, validate=True)
        elif kind == "integer":
            if not isinstance(value, int) or isinstance(value, bool):
                raise Failure(f"{where}: expected an integer, got {value!r}")
            if value < schema.get("minimum", value) or value > schema.get("maximum", value):
                raise Failure(f"{where}: {value} out of range")
        elif kind == "number":
            if not isinstance(value, (int, float)) or isinstance(value, bool):
                raise Failure(f"{where}: expected a number, got {value!r}")
        elif kind == "boolean":
            if not isinstance(value, bool):
                raise Failure(f"{where}: expected a boolean, got {value!r}")

    # ---- calls ----
    def url(self, op_id, path_params, query):
        method, path, op = self.ops[op_id]
        declared = {p["name"]: p for p in op.get("parameters", [])}
        for name in path_params:
            if declared.get(name, {}).get("in") != "path":
                raise Failure(f"{op_id}: {name} is not a path parameter in the document")
            path = path.replace("{" + name + "}", urllib.parse.quote(str(path_params[name]), safe=""))
        pairs = []
        for name, value in (query or {}).items():
            if declared.get(name, {}).get("in") != "query":
                raise Failure(f"{op_id}: {name} is not a query parameter in the document")
            for v in value if isinstance(value, list) else [value]:
                pairs.append((name, str(v).lower() if isinstance(v, bool) else str(v)))
        return method, self.base + path + ("?" + urllib.parse.urlencode(pairs) if pairs else "")

    def call(self, op_id, path_params=None, query=None, body=None, raw=None, token="default",
             content_type=None, expect=200, headers=None):
        method, url = self.url(op_id, path_params or {}, query)
        op = self.ops[op_id][2]
        data, sent_headers = None, dict(headers or {})
        if body is not None:
            data = json.dumps(body).encode()
            sent_headers["Content-Type"] = content_type or "application/json"
        elif raw is not None:
            data = raw
            sent_headers["Content-Type"] = content_type or "application/octet-stream"
        elif "requestBody" in op and "application/json" in op["requestBody"]["content"]:
            data = b""
            sent_headers["Content-Type"] = content_type or "application/json"
        token = self.token if token == "default" else token
        if token:
            sent_headers["Authorization"] = "Bearer " + token
        request = urllib.request.Request(url, data=data, method=method, headers=sent_headers)
        try:
            with urllib.request.urlopen(request, timeout=120) as response:
                status, payload, ctype = response.status, response.read(), response.headers.get("Content-Type", "")
        except urllib.error.HTTPError as e:
            status, payload, ctype = e.code, e.read(), e.headers.get("Content-Type", "")
        if status != expect:
            raise Failure(f"{op_id} {method} {url}: status {status}, expected {expect}: {payload[:400]!r}")
        responses = op["responses"]
        answer = responses.get(str(status), responses.get("default"))
        if ctype.startswith("application/json"):
            value = json.loads(payload)
            self.validate(answer["content"]["application/json"]["schema"], value, f"{op_id} answer")
            return value
        documented = answer.get("content", {})
        if ctype.split(";")[0] not in documented:
            raise Failure(f"{op_id}: content type {ctype} is not documented ({list(documented)})")
        return payload


def stream_events(api, job_id, seen, done):
    """StreamEvents (Server-Sent Events) until the job's job.done arrives."""
    method, url = api.url("StreamEvents", {}, {"job_id": job_id})
    request = urllib.request.Request(url, headers={"Authorization": "Bearer " + api.token})
    schema = {"$ref": "#/components/schemas/FarmEvent"}
    with urllib.request.urlopen(request, timeout=300) as response:
        seen.append(("content-type", response.headers.get("Content-Type")))
        event = {}
        for line in response:
            line = line.decode().rstrip("\n")
            if line == "":
                if "data" in event and event.get("event") != "missed":
                    data = json.loads(event["data"])
                    api.validate(schema, data, "event")
                    seen.append((event.get("id"), event.get("event"), data))
                    if data["type"] == "job.done" and data["job_id"] == job_id:
                        done.set()
                        return
                event = {}
            elif not line.startswith(":") and ":" in line:
                key, value = line.split(":", 1)
                event[key] = value[1:] if value.startswith(" ") else value


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--base", required=True)
    parser.add_argument("--token-file", required=True)
    parser.add_argument("--document", required=True)
    parser.add_argument("--scene", required=True)
    parser.add_argument("--asset", action="append", default=[])  # PATH_IN_SCENE=FILE
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    token = open(args.token_file).read().strip()
    document = json.load(open(args.document))
    api = Api(args.base, token, document)

    # The served document is the one the client was written from.
    served = json.loads(urllib.request.urlopen(args.base + "/api/v1/openapi.json", timeout=30).read())
    check(served == document, "GET /api/v1/openapi.json is the document this client was written from")

    # Refusals, each the document's Error.
    err = api.call("ListJobs", token=None, expect=401)
    check(err["error"]["status"] == "UNAUTHENTICATED", "no token: 401 UNAUTHENTICATED")
    err = api.call("ListJobs", token="x" * 40, expect=401)
    check("wrong" in err["error"]["message"], "a forged token: 401 naming it wrong")

    # Assets: which are missing, upload them, then none is.
    assets = []
    for spec in args.asset:
        path, file = spec.split("=", 1)
        data = open(file, "rb").read()
        assets.append((path, hashlib.sha256(data).hexdigest(), data))
    hashes = [a[1] for a in assets]
    missing = api.call("FindMissingAssets", body={"sha256": hashes})
    check(sorted(missing["missing_sha256"]) == sorted(hashes), "FindMissingAssets lists the new assets")
    wrong = api.call("UploadAsset", {"sha256": hashes[0]}, raw=b"not the bytes", expect=400)
    check(wrong["error"]["status"] == "INVALID_ARGUMENT", "an asset whose bytes do not match its hash: 400")
    for path, sha, data in assets:
        up = api.call("UploadAsset", {"sha256": sha}, raw=data)
        check(up["sha256"] == sha, f"UploadAsset {path} ({len(data)} bytes)")
    again = api.call("FindMissingAssets", body={"sha256": hashes})
    check(again["missing_sha256"] == [], "after the upload none is missing")

    scene_text = open(args.scene).read()
    spec = {"scene_name": "scene.json", "scene_json": scene_text,
            "assets": [{"path": p, "sha256": s} for p, s, _ in assets]}

    # Wrong types and unknown fields: 400, nothing submitted.
    before = len(api.call("ListJobs")["jobs"])
    bad = api.call("SubmitJob", body={"spec": spec, "priority": "high"}, expect=400)
    check("priority" in bad["error"]["message"], "SubmitJob with a string priority: 400 naming priority")
    bad = api.call("SubmitJob", body={"spec": spec, "colour": 1}, expect=400)
    check("colour" in bad["error"]["message"], "SubmitJob with an unknown field: 400 naming it")
    bad = api.call("SubmitJob", body={"spec": spec}, content_type="text/plain", expect=415)
    check(bad["error"]["status"] == "INVALID_ARGUMENT", "SubmitJob without a JSON content type: 415")
    check(len(api.call("ListJobs")["jobs"]) == before, "the refused submissions left no job")
    bad = api.call("ListJobs", query={"limit": "many"}, expect=400)
    check("limit" in bad["error"]["message"], "a query parameter of the wrong type: 400 naming it")

    # The job, its events as they happen, its image.
    submitted = api.call("SubmitJob", body={"spec": spec, "owner": "pipeline"})
    job = submitted["job_id"]
    check(re.fullmatch(r"job-[0-9]+", job) is not None, f"SubmitJob answered {job}")
    seen, done = [], threading.Event()
    listener = threading.Thread(target=stream_events, args=(api, job, seen, done), daemon=True)
    listener.start()
    deadline = time.time() + 300
    status = None
    while time.time() < deadline:
        status = api.call("GetJob", {"job_id": job})
        if status["state"] in ("JOB_STATE_DONE", "JOB_STATE_FAILED", "JOB_STATE_CANCELLED"):
            break
        time.sleep(0.2)
    check(status["state"] == "JOB_STATE_DONE", f"GetJob: {job} done ({status['state']})")
    check(status["progress"]["units_done"] == status["progress"]["units_total"],
          "its units_done equals units_total (64-bit integers as strings)")
    check(done.wait(60), "StreamEvents delivered the job's job.done")
    check(seen[0] == ("content-type", "text/event-stream"), "the stream is text/event-stream")
    types = [t for (_, t, _) in seen[1:]]
    check(types[0] == "job.submitted" and "job.started" in types and types[-1] == "job.done",
          f"its events in order: {types}")
    ids = [int(i) for (i, _, _) in seen[1:]]
    check(ids == sorted(ids) and len(set(ids)) == len(ids), "event ids grow")
    listed = api.call("ListEvents", query={"after": 0, "job_id": job})
    check([e["type"] for e in listed["events"]] == types, "ListEvents gives the same events as the stream")

    exr = api.call("Download", {"job_id": job}, query={"format": "IMAGE_FORMAT_EXR"})
    check(exr[:4] == b"\x76\x2f\x31\x01", f"Download format=IMAGE_FORMAT_EXR is OpenEXR ({len(exr)} bytes)")
    open(args.out, "wb").write(exr)
    png = api.call("Download", {"job_id": job}, query={"format": "IMAGE_FORMAT_PNG", "ev": 0.5})
    check(png[:8] == b"\x89PNG\r\n\x1a\n", "Download format=IMAGE_FORMAT_PNG is a PNG")
    snap = api.call("GetSnapshot", {"job_id": job}, query={"max_size": 32})
    check(base64.b64decode(snap["png"])[:4] == b"\x89PNG" and max(snap["width"], snap["height"]) <= 32,
          "GetSnapshot: a base64 PNG within max_size")
    info = api.call("GetServerInfo")
    check(info["api"] == "lensfarm.v1" and info["renderer_version"].startswith("lensfarm-renderer/"),
          f"GetServerInfo: {info}")
    workers = api.call("ListWorkers")["workers"]
    check(len(workers) >= 1 and all(int(w["units_done"]) >= 0 for w in workers), f"ListWorkers: {len(workers)}")

    # A second job through every action.
    second = api.call("SubmitJob", body={"spec": spec, "paused": True})["job_id"]
    updated = api.call("UpdateJob", {"job_id": second}, body={"priority": 7, "max_workers": 1})
    check(updated["status"]["priority"] == 7 and updated["status"]["policy"]["max_workers"] == 1,
          "UpdateJob (PATCH): priority 7, max_workers 1")
    bad = api.call("UpdateJob", {"job_id": second}, body={"max_workers": 0}, expect=400)
    check("max_workers" in bad["error"]["message"] or "max-workers" in bad["error"]["message"],
          "UpdateJob with a cap of 0: 400 naming it")
    check(api.call("GetJob", {"job_id": second})["policy"]["max_workers"] == 1, "the refused update changed nothing")
    check(api.call("ResumeJob", {"job_id": second})["status"]["paused"] is False, "ResumeJob")
    check(api.call("PauseJob", {"job_id": second})["status"]["paused"] is True, "PauseJob")
    check(api.call("ApproveJob", {"job_id": second})["status"]["approved"] is True, "ApproveJob")
    check(api.call("CancelJob", {"job_id": second})["status"]["state"] == "JOB_STATE_CANCELLED", "CancelJob")
    api.call("DeleteJob", {"job_id": second})
    gone = api.call("GetJob", {"job_id": second}, expect=404)
    check(gone["error"]["status"] == "NOT_FOUND", "DeleteJob: then GetJob is 404")
    check(api.call("PauseJob", {"job_id": "job-999"}, expect=404)["error"]["status"] == "NOT_FOUND",
          "an action on an unknown job: 404")
    # (resumed, a worker may lease a unit before the pause: job.started may come between)
    names = [e["type"] for e in api.call("ListEvents", query={"job_id": second})["events"] if e["type"] != "job.started"]
    check(names == ["job.submitted", "job.resumed", "job.paused", "job.approved", "job.cancelled", "job.deleted"],
          f"the second job's events: {names}")
    print("all checks passed")


if __name__ == "__main__":
    try:
        main()
    except Failure as failure:
        print("FAILED:", failure)
        sys.exit(1)
