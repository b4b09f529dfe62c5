"""The Python library `lensfarm` (python/lensfarm) against a real coordinator and real workers,
started by tests/python/python_client_test.cpp, which then checks the downloaded image's bits
against `lensfarm render`'s.

    PYTHONPATH=build/python python3 tests/python/client_checks.py --address HOST:PORT \
        --token-file F --scene scene.json --out image.exr --unused-address HOST:PORT [--case NAME]

Each case prints "ok NAME" or raises; the last line is "all checks passed".
"""

import argparse
import json
import os
import shutil
import sys
import tempfile
import threading
import time
import warnings
from concurrent import futures
from pathlib import Path

import grpc

import lensfarm
from lensfarm.v1 import client_service_pb2 as pb
from lensfarm.v1 import client_service_pb2_grpc as pb_grpc

TIMEOUT = 300  # seconds a job may take on a loaded 2-core machine


def expect(condition, what):
    if not condition:
        raise AssertionError(what)


def expect_raises(kind, call, contains=""):
    try:
        call()
    except kind as e:
        expect(contains in str(e), f"{kind.__name__} should say {contains!r}: {e}")
        return e
    except Exception as e:  # noqa: BLE001 - the wrong kind is the failure reported
        raise AssertionError(f"expected {kind.__name__}, got {type(e).__name__}: {e}") from e
    raise AssertionError(f"expected {kind.__name__}, nothing was raised")


def case_render(args, farm):
    """Submit a scene file (its OBJ found and uploaded), wait with a callback, download the EXR."""
    info = farm.server_info()
    expect(info.api == "lensfarm.v1" and info.renderer_version == lensfarm.RENDERER_VERSION, f"server info {info}")
    expect(info.identity == "client" and info.role == "client", f"the shared token is the client: {info}")
    job = farm.submit(args.scene, priority=1)
    expect(job.job_id.startswith("job-"), f"a job id: {job.job_id}")
    seen = []
    final = farm.wait(job, on_status=seen.append, timeout=TIMEOUT)
    expect(lensfarm.state_name(final) == "done", f"done: {lensfarm.describe(final)}")
    expect(len(seen) >= 1 and seen[-1].state == final.state, "the callback saw the end")
    versions = [s.version for s in seen]
    expect(versions == sorted(versions), f"statuses in order: {versions}")
    expect(final.progress.samples_per_pixel_done == final.progress.samples_per_pixel_total, "every sample")
    path = farm.download(job, args.out)
    expect(Path(path) == Path(args.out) and Path(args.out).stat().st_size > 0, "written")
    expect(not [p for p in Path(args.out).parent.iterdir() if p.name.startswith(f".{Path(args.out).name}.")],
           "no temporary file left")
    data = farm.download(job)
    expect(data == Path(args.out).read_bytes(), "bytes and file are the same image")
    png = farm.download(job.job_id, format="png")
    expect(png[:8] == b"\x89PNG\r\n\x1a\n", "a PNG")
    snap = farm.snapshot(job, max_size=8)
    expect(max(snap.width, snap.height) <= 8 and snap.png[:4] == b"\x89PNG", "a small preview")
    # The same scene again: its OBJ is on the coordinator already, nothing is uploaded.
    spec, blobs = farm._spec(args.scene, None, None, None)
    expect(len(blobs) == 1 and [a.path for a in spec.assets] == ["meshes/cornell-box.obj"], f"assets {spec.assets}")
    expect(farm.upload_assets(blobs) == 0, "an asset the coordinator holds is not sent again")
    return job


def case_listing(args, farm, job):
    status = farm.status(job.job_id)
    expect(status.job_id == job.job_id and lensfarm.state_name(status) == "done", "status")
    expect(job.job_id in [j.job_id for j in farm.jobs(states=["done"])], "listed as done")
    expect(farm.jobs(states=["failed"]) == [] or job.job_id not in [j.job_id for j in farm.jobs(states=["failed"])],
           "not listed as failed")
    workers = farm.workers()
    expect(sorted(w.name for w in workers) == ["w1", "w2"], f"two workers: {[w.name for w in workers]}")
    expect(sum(w.units_done for w in workers) >= status.progress.units_done, "the workers rendered it")
    events = farm.events(job=job.job_id).events
    types = [e.type for e in events]
    expect("job.submitted" in types and "job.done" in types, f"events {types}")
    expect(all(e.job_id == job.job_id for e in events), "only the job's events")
    expect([e.sequence for e in events] == sorted(e.sequence for e in events), "in order")


def case_actions(args, farm):
    """A paused job: pause/resume/update/cancel, wait raising JobCancelled; follow_events sees it."""
    seen = []
    start = farm.events(limit=1).latest

    def follow():
        for event in farm.follow_events(after=start):
            seen.append(event)
            if event.type == "job.cancelled":
                return

    follower = threading.Thread(target=follow, daemon=True)
    follower.start()
    job = farm.submit(args.scene, paused=True, samples=4096, owner="pipeline")
    expect(job.paused and job.owner == "pipeline", f"submitted paused: {job}")
    expect(farm.update(job, priority=5, max_workers=1).priority == 5, "priority changed")
    expect(farm.status(job).policy.max_workers == 1, "cap changed")
    expect(farm.resume(job).paused is False, "resumed")
    expect(farm.pause(job).paused is True, "paused again")
    cancelled = farm.cancel(job)
    expect(lensfarm.state_name(cancelled) == "cancelled", "cancelled")
    error = expect_raises(lensfarm.JobCancelled, lambda: farm.wait(job, timeout=60))
    expect(error.status.job_id == job.job_id, "the error carries the status")
    expect(lensfarm.state_name(farm.wait(job, check=False, timeout=60)) == "cancelled", "check=False returns it")
    follower.join(60)
    types = [e.type for e in seen if e.job_id == job.job_id]
    expect("job.submitted" in types and "job.cancelled" in types, f"followed events {types}")
    farm.delete(job)
    expect_raises(lensfarm.NotFound, lambda: farm.status(job), job.job_id)


def case_dict_scene(args, farm):
    """A scene given as a dict, its OBJ as bytes: rendered like the file."""
    scene = json.loads(Path(args.scene).read_text())
    scene["render"]["samples_per_pixel"] = 4
    obj = (Path(args.scene).parent / "meshes/cornell-box.obj").read_bytes()
    job = farm.submit(scene, assets={"meshes/cornell-box.obj": obj}, name="from-a-dict.json")
    expect(job.scene_name == "from-a-dict.json", f"named {job.scene_name}")
    final = farm.wait(job, timeout=TIMEOUT)
    expect(lensfarm.state_name(final) == "done", lensfarm.describe(final))


def case_model_file(args, farm):
    """A model file (OBJ) is rendered as `lensfarm render MODEL` would: the scene written for it."""
    folder = Path(tempfile.mkdtemp())
    try:
        (folder / "tri.obj").write_text("mtllib tri.mtl\nv -1 -1 3\nv 1 -1 3\nv 0 1 3\nusemtl white\nf 1 2 3\n")
        (folder / "tri.mtl").write_text("newmtl white\nKd 0.8 0.8 0.8\nKe 1 1 1\n")
        spec, blobs = farm._spec(folder / "tri.obj", None, None, None)
        expect(sorted(a.path for a in spec.assets) == ["tri.mtl", "tri.obj"], f"the MTL found: {spec.assets}")
        job = farm.submit(folder / "tri.obj", samples=1, width=8, height=8)
        final = farm.wait(job, timeout=TIMEOUT)
        expect(lensfarm.state_name(final) == "done" and final.width == 8, lensfarm.describe(final))
    finally:
        shutil.rmtree(folder)


def case_bad_input(args, farm):
    scene = json.loads(Path(args.scene).read_text())
    scene["render"]["samples_per_pixel"] = -3
    error = expect_raises(lensfarm.InvalidArgument, lambda: farm.submit(scene, assets={
        "meshes/cornell-box.obj": Path(args.scene).parent / "meshes/cornell-box.obj"}), "samples_per_pixel")
    expect(error.code == grpc.StatusCode.INVALID_ARGUMENT and error.rpc == "SubmitJob", "typed with its status")
    expect_raises(lensfarm.NotFound, lambda: farm.status("job-999999"), "job-999999")
    expect_raises(lensfarm.NotFound, lambda: farm.submit(args.scene, after=["job-999999:done"]), "job-999999")
    expect_raises(lensfarm.InvalidArgument, lambda: farm.submit(args.scene, after=["job-1:soon"]), "soon")
    expect_raises(lensfarm.InvalidArgument, lambda: farm.submit(args.scene, max_workers=0), "max_workers")
    expect_raises(TypeError, lambda: farm.submit(args.scene, sampels=4), "sampels")
    expect_raises(lensfarm.SceneError, lambda: farm.submit("/nonexistent/scene.json"), "no such scene file")
    broken = Path(tempfile.mkdtemp()) / "broken.json"
    broken.write_text('{"format": "lensfarm-scene/1",\n "camera": }')
    expect_raises(lensfarm.SceneError, lambda: farm.submit(broken), "line 2")
    # Without its OBJ the coordinator says which file the scene could not read.
    lonely = broken.parent / "lonely.json"
    lonely.write_text(Path(args.scene).read_text())
    expect_raises(lensfarm.InvalidArgument, lambda: farm.submit(lonely), "cornell-box.obj")
    shutil.rmtree(broken.parent)
    expect_raises(lensfarm.InvalidArgument, lambda: farm.events(wait=99), "wait_seconds")


def case_wrong_token(args):
    with lensfarm.Client(args.address, token="not-the-farms-token-at-all") as farm:
        error = expect_raises(lensfarm.Unauthenticated, farm.server_info, "token")
        expect(error.code == grpc.StatusCode.UNAUTHENTICATED, "its status")
        expect("not-the-farms-token" not in str(error), "the token is never shown")
        expect_raises(lensfarm.Unauthenticated, lambda: farm.status("job-1"))
    expect_raises(lensfarm.Unauthenticated, lambda: lensfarm.connect(args.address))
    loose = Path(tempfile.mkdtemp()) / "token"
    loose.write_text("whatever-token-1234567\n")
    loose.chmod(0o644)
    expect_raises(lensfarm.LensfarmError, lambda: lensfarm.Client(args.address, token_file=loose), "chmod 600")
    shutil.rmtree(loose.parent)


def case_unreachable(args):
    started = time.monotonic()
    error = expect_raises(lensfarm.Unavailable, lambda: lensfarm.connect(args.unused_address, timeout=10),
                          args.unused_address)
    expect(error.code == grpc.StatusCode.UNAVAILABLE, "its status")
    expect(time.monotonic() - started < 60, "said within the call's timeout")


class _OtherApi(pb_grpc.ClientServiceServicer):
    def __init__(self, api):
        self.api = api

    def GetServerInfo(self, request, context):
        return pb.ServerInfo(renderer_version="lensfarm-renderer/9.0.0", api=self.api)


def case_version_check(args):
    """The library checks the coordinator's API: another package, or no GetServerInfo at all (an
    older coordinator), is IncompatibleCoordinator; another renderer version only warns."""
    for api, kind, says in (("lensfarm.v2", lensfarm.IncompatibleCoordinator, "lensfarm.v2"),
                            (None, lensfarm.IncompatibleCoordinator, "predates GetServerInfo"),
                            ("lensfarm.v1", None, "lensfarm-renderer/9.0.0")):
        server = grpc.server(futures.ThreadPoolExecutor(max_workers=2))
        if api is not None:
            pb_grpc.add_ClientServiceServicer_to_server(_OtherApi(api), server)
        port = server.add_insecure_port("127.0.0.1:0")
        server.start()
        try:
            if kind is not None:
                expect_raises(kind, lambda: lensfarm.connect(f"127.0.0.1:{port}"), says)
            else:
                with warnings.catch_warnings(record=True) as caught:
                    warnings.simplefilter("always")
                    lensfarm.connect(f"127.0.0.1:{port}").close()
                expect(any(issubclass(w.category, lensfarm.VersionWarning) and says in str(w.message)
                           for w in caught), f"a version warning: {[str(w.message) for w in caught]}")
        finally:
            server.stop(None)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--address", required=True)
    parser.add_argument("--token-file", required=True)
    parser.add_argument("--scene", required=True)
    parser.add_argument("--out", required=True)
    parser.add_argument("--unused-address", required=True)
    args = parser.parse_args()
    with lensfarm.connect(args.address, token_file=args.token_file) as farm:
        job = case_render(args, farm)
        print("ok render", flush=True)
        case_listing(args, farm, job)
        print("ok listing", flush=True)
        case_actions(args, farm)
        print("ok actions", flush=True)
        case_dict_scene(args, farm)
        print("ok dict scene", flush=True)
        case_model_file(args, farm)
        print("ok model file", flush=True)
        case_bad_input(args, farm)
        print("ok bad input", flush=True)
    case_wrong_token(args)
    print("ok wrong token", flush=True)
    case_unreachable(args)
    print("ok unreachable", flush=True)
    case_version_check(args)
    print("ok version check", flush=True)
    print("all checks passed")


if __name__ == "__main__":
    sys.exit(main())
