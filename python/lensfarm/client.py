"""The coordinator's ClientService (proto/lensfarm/v1/client_service.proto) for Python programs.

    import lensfarm

    with lensfarm.Client("farm:7878", token_file="~/.lensfarm-token") as farm:
        job = farm.submit("scenes/cornell-seed.json", samples_per_pixel=256)
        farm.wait(job, on_status=lambda s: print(lensfarm.describe(s)))
        farm.download(job, "cornell.exr")

Answers are the protocol's own messages (lensfarm.v1.JobStatus, WorkerStatus, FarmEvent: every
field the proto documents); failures are typed errors (errors.py) carrying the gRPC status and the
coordinator's message. Calls are synchronous and thread-safe; one Client holds one channel.
"""

from __future__ import annotations

import hashlib
import json
import os
import posixpath
import tempfile
import time
import warnings
from pathlib import Path
from typing import Callable, Dict, Iterable, Iterator, List, Mapping, Optional, Sequence, Tuple, Union

import grpc

from . import _version
from .assets import find_assets, iter_chunks, read_assets
from .errors import (DeadlineExceeded, IncompatibleCoordinator, InvalidArgument, JobCancelled, JobFailed,
                     LensfarmError, SceneError, Unavailable, Unimplemented, from_rpc_error)
from .v1 import client_service_pb2 as pb
from .v1 import client_service_pb2_grpc as pb_grpc
from .v1 import common_pb2 as common

JobRef = Union[str, "common.JobStatus"]
SceneInput = Union[str, os.PathLike, Mapping]

API = "lensfarm.v1"  # the protobuf package this library was generated from
_MODEL_EXTENSIONS = (".gltf", ".glb", ".obj", ".usda", ".usd", ".usdc", ".usdz")
_ENDED = (common.JOB_STATE_DONE, common.JOB_STATE_CANCELLED, common.JOB_STATE_FAILED)
# The most hashes one FindMissingAssets call takes (client_service.proto).
_MOST_HASHES = 50000


def _job_id(job: JobRef) -> str:
    if isinstance(job, str):
        return job
    if hasattr(job, "job_id"):
        return job.job_id
    raise TypeError(f"a job is its id (str) or a JobStatus, not {type(job).__name__}")


def state_name(status: "common.JobStatus") -> str:
    """"queued", "running", "done", "cancelled" or "failed"."""
    return common.JobState.Name(status.state)[len("JOB_STATE_"):].lower()


def describe(status: "common.JobStatus") -> str:
    """One line for people: "job-3 running: 96/256 spp, error 2.4 %, 41 s left, 2 workers"."""
    p = status.progress
    parts = [f"{p.samples_per_pixel_done}/{p.samples_per_pixel_total} spp"]
    if p.estimated_relative_error >= 0:
        parts.append(f"error {100 * p.estimated_relative_error:.2g} %")
    if p.remaining_seconds > 0 and status.state == common.JOB_STATE_RUNNING:
        parts.append(f"{p.remaining_seconds:.0f} s left")
    if status.state == common.JOB_STATE_RUNNING:
        parts.append(f"{p.workers_busy} worker{'s' if p.workers_busy != 1 else ''}")
    extra = ""
    if status.paused:
        extra = " (paused)"
    elif p.stalled_reason:
        extra = f" ({p.stalled_reason})"
    elif status.waiting_for:
        extra = f" (waits for {'; '.join(status.waiting_for)})"
    elif status.error:
        extra = f" ({status.error})"
    return f"{status.job_id} {state_name(status)}: {', '.join(parts)}{extra}"


def _read_secret(path: Union[str, os.PathLike]) -> str:
    p = Path(os.path.expanduser(str(path)))
    try:
        mode = p.stat().st_mode
        text = p.read_text()
    except OSError as e:
        raise LensfarmError(f"token file {p}: cannot read: {e.strerror}") from None
    if mode & 0o007:
        raise LensfarmError(f"token file {p}: others may read it; run: chmod 600 {p}")
    token = text.strip()
    if not token:
        raise LensfarmError(f"token file {p}: is empty")
    return token


def _read_pem(path: Optional[Union[str, os.PathLike]], what: str) -> Optional[bytes]:
    if path is None:
        return None
    try:
        return Path(os.path.expanduser(str(path))).read_bytes()
    except OSError as e:
        raise LensfarmError(f"{what} {path}: cannot read: {e.strerror}") from None


class _Token(grpc.AuthMetadataPlugin):
    def __init__(self, token: str):
        self._metadata = (("authorization", f"Bearer {token}"),)

    def __call__(self, context, callback):
        callback(self._metadata, None)


class Client:
    """A connection to one coordinator.

    address: HOST:PORT (default: $LENSFARM_COORDINATOR, else 127.0.0.1:7878).
    token / token_file: the client token or a person's (default: $LENSFARM_TOKEN); a token file
        must not be readable by others. Never logged or written anywhere.
    tls_ca / tls_cert / tls_key: PEM files, as the CLI's --tls-ca/--tls-cert/--tls-key: a CA
        enables TLS; the certificate and key are for coordinators that require client certificates.
    timeout: seconds for each unary call (streams and waits take their own).
    check: on the first call, ask the coordinator who it is (GetServerInfo) and raise
        IncompatibleCoordinator if it serves another API; a wrong token raises Unauthenticated then.
    """

    def __init__(self, address: Optional[str] = None, *, token: Optional[str] = None,
                 token_file: Optional[Union[str, os.PathLike]] = None, tls_ca=None, tls_cert=None, tls_key=None,
                 timeout: float = 30.0, check: bool = True, options: Sequence[Tuple[str, object]] = ()):
        self.address = address or os.environ.get("LENSFARM_COORDINATOR") or "127.0.0.1:7878"
        if token is not None and token_file is not None:
            raise ValueError("give token or token_file, not both")
        if token_file is not None:
            token = _read_secret(token_file)
        elif token is None:
            token = os.environ.get("LENSFARM_TOKEN") or None
        self.timeout = timeout
        self._check = check
        self._info: Optional[pb.ServerInfo] = None
        channel_options = [("grpc.max_receive_message_length", 16 << 20), *options]
        ca = _read_pem(tls_ca, "tls_ca")
        if (tls_cert is None) != (tls_key is None):
            raise ValueError("tls_cert and tls_key go together")
        if ca is not None:
            credentials = grpc.ssl_channel_credentials(ca, _read_pem(tls_key, "tls_key"),
                                                       _read_pem(tls_cert, "tls_cert"))
            if token:
                credentials = grpc.composite_channel_credentials(credentials,
                                                                 grpc.metadata_call_credentials(_Token(token)))
            self._channel = grpc.secure_channel(self.address, credentials, channel_options)
            self._metadata: Tuple[Tuple[str, str], ...] = ()
        else:
            if tls_cert is not None:
                raise ValueError("a client certificate needs TLS: give tls_ca too")
            self._channel = grpc.insecure_channel(self.address, channel_options)
            # Plain gRPC (loopback, or behind a TLS-terminating proxy): the token goes as metadata,
            # which grpc's call credentials would refuse to send without TLS.
            self._metadata = (("authorization", f"Bearer {token}"),) if token else ()
        self._stub = pb_grpc.ClientServiceStub(self._channel)

    # ---- connection ----------------------------------------------------------------------------

    def close(self) -> None:
        self._channel.close()

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _call(self, rpc: str, request, timeout: Optional[float] = None, check: bool = True):
        if check:
            self._ensure_checked()
        try:
            return getattr(self._stub, rpc)(request, timeout=timeout or self.timeout, metadata=self._metadata)
        except grpc.RpcError as e:
            raise self._error(e, rpc) from None

    def _error(self, e: grpc.RpcError, rpc: str) -> LensfarmError:
        error = from_rpc_error(e, rpc)
        if isinstance(error, Unavailable):
            error.details = f"cannot reach the coordinator at {self.address}: {error.details}"
            error.args = (f"{rpc}: {error.details}",)
        return error

    def _ensure_checked(self) -> None:
        if self._check and self._info is None:
            self.server_info()

    def server_info(self) -> "pb.ServerInfo":
        """Who the coordinator is (renderer version, API) and who this client is to it (identity,
        role). Raises IncompatibleCoordinator if it serves another API than this library's."""
        try:
            info = self._call("GetServerInfo", pb.GetServerInfoRequest(), check=False)
        except Unimplemented:
            raise IncompatibleCoordinator(
                f"the coordinator at {self.address} predates GetServerInfo (lensfarm-renderer/0.7.0): "
                f"this library ({_version.__version__}) needs a coordinator of 0.7.0 or newer") from None
        if info.api != API:
            raise IncompatibleCoordinator(
                f"the coordinator at {self.address} serves {info.api or 'an unnamed API'} "
                f"({info.renderer_version}); this library ({_version.__version__}) speaks {API}")
        if info.renderer_version != _version.RENDERER_VERSION:
            # lensfarm.v1 only ever gains fields, so a call of either side is understood; say it
            # once, as a script may not expect fields the other side lacks.
            warnings.warn(f"coordinator {self.address} runs {info.renderer_version}, this library "
                          f"{_version.RENDERER_VERSION}", VersionWarning, stacklevel=3)
        self._info = info
        return info

    # ---- submitting ----------------------------------------------------------------------------

    def submit(self, scene: SceneInput, *, assets: Optional[Mapping[str, Union[bytes, str, os.PathLike]]] = None,
               name: Optional[str] = None, priority: int = 0, owner: Optional[str] = None,
               frames: Optional[Union[Tuple[int, int], Tuple[int, int, int]]] = None, paused: bool = False,
               after: Iterable[str] = (), on_dependency_failure: str = "fail", require_tags: Iterable[str] = (),
               prefer_tags: Iterable[str] = (), audit_require_tags: Iterable[str] = (),
               max_workers: Optional[int] = None, share_weight: float = 0.0,
               max_unit_failures: Optional[int] = None, max_worker_failures: Optional[int] = None,
               unit_time_limit: Optional[float] = None, on_failure: str = "fail",
               base_dir: Optional[Union[str, os.PathLike]] = None, **overrides) -> "common.JobStatus":
        """Submits a job; returns its status (``.job_id``).

        scene: a scene file (lensfarm-scene/1 JSON, or a .gltf/.glb/.obj model rendered as it is),
            or a scene as a dict (its assets then from ``assets`` and from ``base_dir``).
        assets: more files, {path as the scene writes it: bytes or a file}; those found beside
            the scene (assets.py) are added by themselves.
        frames: an animation's (first, last[, step]); None: a still.
        after: dependencies as the CLI's --after: "job-7", "job-7:failed", "job-7:ended",
            "job-7:approved", "job-7:error<=2%".
        **overrides: RenderOverrides fields (samples_per_pixel, width, height, max_bounces, seed,
            integrator, ev, sampler, russian_roulette, target_error, time_limit_seconds, tile_size,
            aovs, adaptive, kernel); ``samples`` is samples_per_pixel.
        Uploads only the assets the coordinator lacks. Raises SceneError for a file it cannot
        read, and the coordinator's errors (InvalidArgument naming the field, NotFound naming a
        job waited for, ResourceExhausted naming a quota).
        """
        spec, blobs = self._spec(scene, assets, name, base_dir)
        spec.overrides.CopyFrom(render_overrides(**overrides))
        if frames is not None:
            first, last, *step = frames
            spec.frames.CopyFrom(common.FrameRange(first=first, last=last, step=step[0] if step else 1))
        policy = job_policy(after=after, on_dependency_failure=on_dependency_failure, require_tags=require_tags,
                            prefer_tags=prefer_tags, audit_require_tags=audit_require_tags, max_workers=max_workers,
                            share_weight=share_weight, max_unit_failures=max_unit_failures,
                            max_worker_failures=max_worker_failures, unit_time_limit=unit_time_limit,
                            on_failure=on_failure)
        self.upload_assets(blobs)
        request = pb.SubmitJobRequest(spec=spec, priority=priority, owner=owner or os.environ.get("USER", ""),
                                      policy=policy, paused=paused)
        return self._call("SubmitJob", request).status

    def _spec(self, scene: SceneInput, extra, name, base_dir) -> Tuple["common.JobSpec", Dict[str, bytes]]:
        files: Dict[str, Path] = {}
        if isinstance(scene, Mapping):
            scene_dict = dict(scene)
            text = json.dumps(scene_dict, indent=2)
            scene_name = name or "scene.json"
            folder = Path(base_dir) if base_dir is not None else None
        else:
            path = Path(os.path.expanduser(str(scene)))
            if not path.is_file():
                raise SceneError(f"{path}: no such scene file")
            folder = path.resolve().parent
            scene_name = name or path.name
            if path.suffix.lower() in _MODEL_EXTENSIONS:
                # A model rendered as it is: the scene `lensfarm render MODEL` writes for it.
                scene_dict = model_scene(path.name)
                text = json.dumps(scene_dict, indent=2)
            else:
                try:
                    text = path.read_text(encoding="utf-8")
                    scene_dict = json.loads(text)
                except (OSError, UnicodeDecodeError) as e:
                    raise SceneError(f"{path}: cannot read: {e}") from None
                except json.JSONDecodeError as e:
                    raise SceneError(f"{path}: line {e.lineno}, column {e.colno}: not JSON: {e.msg}") from None
                if not isinstance(scene_dict, dict):
                    raise SceneError(f"{path}: is not a JSON object (the scene format)")
        if folder is not None:
            files.update(find_assets(scene_dict, folder))
        blobs_by_path = read_assets(files)
        for rel, value in (extra or {}).items():
            if isinstance(value, (bytes, bytearray, memoryview)):
                blobs_by_path[rel] = bytes(value)
            else:
                blobs_by_path.update(read_assets({rel: Path(value)}))
        spec = common.JobSpec(scene_name=scene_name, scene_json=text)
        blobs: Dict[str, bytes] = {}
        for rel, data in sorted(blobs_by_path.items()):
            sha = hashlib.sha256(data).hexdigest()
            spec.assets.add(path=rel, sha256=sha)
            blobs[sha] = data
        return spec, blobs

    def missing_assets(self, sha256s: Iterable[str]) -> List[str]:
        """Which of these assets (SHA-256, hex) the coordinator does not hold."""
        hashes = list(dict.fromkeys(sha256s))
        missing: List[str] = []
        for i in range(0, len(hashes), _MOST_HASHES):
            answer = self._call("FindMissingAssets", pb.FindMissingAssetsRequest(sha256=hashes[i:i + _MOST_HASHES]))
            missing.extend(answer.missing_sha256)
        return missing

    def upload_assets(self, blobs: Mapping[str, bytes]) -> int:
        """Uploads those of {sha256: bytes} the coordinator lacks; returns how many were sent."""
        if not blobs:
            return 0
        try:
            missing = self.missing_assets(blobs.keys())
        except Unimplemented:
            missing = list(blobs.keys())  # a coordinator older than FindMissingAssets
        for sha in missing:
            self.upload_asset(blobs[sha], sha)
        return len(missing)

    def upload_asset(self, data: bytes, sha256: Optional[str] = None) -> "pb.UploadAssetResponse":
        """Uploads one asset (in 1 MiB chunks); returns the coordinator's answer."""
        sha = sha256 or hashlib.sha256(data).hexdigest()

        def messages() -> Iterator["pb.UploadAssetRequest"]:
            for i, piece in enumerate(iter_chunks(data)):
                chunk = common.FileChunk(data=piece, total_size=len(data) if i == 0 else 0)
                yield pb.UploadAssetRequest(sha256=sha if i == 0 else "", chunk=chunk)

        return self._call("UploadAsset", messages(), timeout=max(self.timeout, 600.0))

    # ---- following -----------------------------------------------------------------------------

    def status(self, job: JobRef) -> "common.JobStatus":
        return self._call("GetJob", pb.GetJobRequest(job_id=_job_id(job)))

    def jobs(self, *, states: Iterable[str] = (), owner: str = "", name_contains: str = "",
             limit: int = 0) -> List["common.JobStatus"]:
        """Jobs in serving order; states by name ("queued", "running", "done", ...)."""
        request = pb.ListJobsRequest(state_names=list(states), owner=owner, name_contains=name_contains, limit=limit)
        return list(self._call("ListJobs", request).jobs)

    def watch(self, job: JobRef, timeout: Optional[float] = None) -> Iterator["common.JobStatus"]:
        """The job's status now and after every change, until it has ended. A stream broken by
        the network (or a coordinator restart) is opened again until `timeout` seconds in all."""
        self._ensure_checked()
        job_id = _job_id(job)
        deadline = None if timeout is None else time.monotonic() + timeout
        pause = 0.2
        while True:
            left = None if deadline is None else deadline - time.monotonic()
            if left is not None and left <= 0:
                raise DeadlineExceeded(f"{job_id} has not ended within {timeout:g} s", "WatchJob")
            try:
                for status in self._stub.WatchJob(pb.WatchJobRequest(job_id=job_id), timeout=left,
                                                  metadata=self._metadata):
                    pause = 0.2
                    yield status
                    if status.state in _ENDED:
                        return
                continue  # the stream ended before the job did (a coordinator stopping)
            except grpc.RpcError as e:
                error = self._error(e, "WatchJob")
                if isinstance(error, DeadlineExceeded):
                    raise DeadlineExceeded(f"{job_id} has not ended within {timeout:g} s", "WatchJob") from None
                if not isinstance(error, Unavailable):
                    raise error from None
            time.sleep(pause if deadline is None else max(0.0, min(pause, deadline - time.monotonic())))
            pause = min(pause * 2, 5.0)

    def wait(self, job: JobRef, *, on_status: Optional[Callable[["common.JobStatus"], None]] = None,
             timeout: Optional[float] = None, check: bool = True) -> "common.JobStatus":
        """Waits until the job has ended, calling on_status(status) at every change; returns the
        last status. check: raise JobFailed / JobCancelled unless it is done."""
        last = None
        for status in self.watch(job, timeout):
            last = status
            if on_status is not None:
                on_status(status)
        if check and last.state == common.JOB_STATE_FAILED:
            raise JobFailed(f"{last.job_id} failed: {last.error}", last)
        if check and last.state == common.JOB_STATE_CANCELLED:
            raise JobCancelled(f"{last.job_id} was cancelled", last)
        return last

    def events(self, *, after: int = 0, job: Optional[JobRef] = None, limit: int = 0,
               wait: float = 0.0) -> "pb.ListEventsResponse":
        """The farm's events after sequence `after` (``.events``, ``.latest``, ``.oldest``);
        wait: up to that many seconds (30 at most) for one when there is none yet."""
        request = pb.ListEventsRequest(after=after, limit=limit, job_id=_job_id(job) if job else "",
                                       wait_seconds=wait)
        return self._call("ListEvents", request, timeout=max(self.timeout, wait + 10))

    def follow_events(self, *, after: Optional[int] = None, job: Optional[JobRef] = None,
                      on_missed: Optional[Callable[[int, int], None]] = None) -> Iterator["common.FarmEvent"]:
        """Events as they happen (long polls), from after `after` (None: from now) for ever.
        on_missed(first, last) is called when the coordinator no longer holds events between."""
        if after is None:
            after = self.events(limit=1).latest
        while True:
            answer = self.events(after=after, job=job, wait=25.0)
            if on_missed is not None and answer.oldest > after + 1 and after > 0:
                on_missed(after + 1, answer.oldest - 1)
            for event in answer.events:
                yield event
                after = event.sequence
            if not answer.events:
                after = max(after, answer.latest if job else after)

    def workers(self) -> List["pb.WorkerStatus"]:
        return list(self._call("ListWorkers", pb.ListWorkersRequest()).workers)

    # ---- acting on jobs ------------------------------------------------------------------------

    def cancel(self, job: JobRef) -> "common.JobStatus":
        return self._call("CancelJob", pb.CancelJobRequest(job_id=_job_id(job))).status

    def pause(self, job: JobRef) -> "common.JobStatus":
        return self._call("PauseJob", pb.JobActionRequest(job_id=_job_id(job))).status

    def resume(self, job: JobRef) -> "common.JobStatus":
        return self._call("ResumeJob", pb.JobActionRequest(job_id=_job_id(job))).status

    def approve(self, job: JobRef) -> "common.JobStatus":
        return self._call("ApproveJob", pb.JobActionRequest(job_id=_job_id(job))).status

    def prefetch(self, job: JobRef) -> "common.JobStatus":
        return self._call("PrefetchJob", pb.JobActionRequest(job_id=_job_id(job))).status

    def update(self, job: JobRef, *, priority: Optional[int] = None, max_workers: Optional[int] = None,
               share_weight: Optional[float] = None) -> "common.JobStatus":
        request = _with(pb.UpdateJobRequest(job_id=_job_id(job)), priority=priority, max_workers=max_workers,
                        share_weight=share_weight)
        return self._call("UpdateJob", request).status

    def archive(self, job: JobRef) -> "common.JobStatus":
        return self._call("ArchiveJob", pb.ArchiveJobRequest(job_id=_job_id(job))).status

    def delete(self, job: JobRef, *, force: bool = False) -> None:
        self._call("DeleteJob", pb.DeleteJobRequest(job_id=_job_id(job), force=force))

    # ---- images --------------------------------------------------------------------------------

    def download(self, job: JobRef, path: Optional[Union[str, os.PathLike]] = None, *, format: str = "exr",
                 frame: Optional[int] = None, ev: Optional[float] = None,
                 timeout: Optional[float] = None) -> Union[bytes, Path]:
        """The image as it is now: linear OpenEXR ("exr") or the exposed PNG ("png"); an
        animation's frame by its scene frame number. With `path`, written there (atomically: a
        temporary file renamed, so no partial file is ever seen) and the path returned; else the
        bytes."""
        kinds = {"exr": pb.IMAGE_FORMAT_EXR, "png": pb.IMAGE_FORMAT_PNG}
        if format not in kinds:
            raise ValueError(f"format: expected 'exr' or 'png', not {format!r}")
        request = _with(pb.DownloadRequest(job_id=_job_id(job), format=kinds[format]), frame=frame, ev=ev)
        self._ensure_checked()
        pieces = []
        try:
            for chunk in self._stub.Download(request, timeout=timeout or max(self.timeout, 600.0),
                                             metadata=self._metadata):
                pieces.append(chunk.data)
        except grpc.RpcError as e:
            raise self._error(e, "Download") from None
        data = b"".join(pieces)
        if path is None:
            return data
        target = Path(os.path.expanduser(str(path)))
        handle, temporary = tempfile.mkstemp(prefix=f".{target.name}.", dir=str(target.parent or "."))
        try:
            with os.fdopen(handle, "wb") as f:
                f.write(data)
            os.replace(temporary, target)
        except BaseException:
            try:
                os.unlink(temporary)
            except OSError:
                pass
            raise
        return target

    def snapshot(self, job: JobRef, *, max_size: int = 512, ev: Optional[float] = None,
                 frame: Optional[int] = None) -> "pb.Snapshot":
        """A small exposed preview (``.png`` bytes, ``.width``, ``.height``) with the job's ``.status``."""
        request = _with(pb.SnapshotRequest(job_id=_job_id(job), max_size=max_size), ev=ev, frame=frame)
        return self._call("GetSnapshot", request)


class VersionWarning(UserWarning):
    """The coordinator runs another renderer version than the library was built with."""


# ---- messages from keyword arguments -----------------------------------------------------------

def _with(message, **optional):
    """`message` with the fields given a value (None: left unset, so an `optional` field stays absent)."""
    for name, value in optional.items():
        if value is not None:
            setattr(message, name, value)
    return message


def render_overrides(**fields) -> "common.RenderOverrides":
    """RenderOverrides from keyword arguments named as its fields (``samples`` for
    samples_per_pixel); TypeError naming an unknown one."""
    if "samples" in fields:
        fields["samples_per_pixel"] = fields.pop("samples")
    known = set(common.RenderOverrides.DESCRIPTOR.fields_by_name)
    unknown = sorted(set(fields) - known)
    if unknown:
        raise TypeError(f"unknown render override(s) {', '.join(unknown)}; known: {', '.join(sorted(known))}")
    return common.RenderOverrides(**{k: v for k, v in fields.items() if v is not None})


_CONDITIONS = {
    "done": common.DEPENDENCY_CONDITION_DONE,
    "failed": common.DEPENDENCY_CONDITION_FAILED,
    "ended": common.DEPENDENCY_CONDITION_ENDED,
    "approved": common.DEPENDENCY_CONDITION_APPROVED,
}


def dependency(text: str) -> "common.Dependency":
    """A dependency as the CLI's --after writes it: JOB[:done|failed|ended|approved|error<=X%]."""
    job, _, condition = text.partition(":")
    if not job:
        raise InvalidArgument(f"after {text!r}: no job id")
    if not condition:
        return common.Dependency(job_id=job, condition=common.DEPENDENCY_CONDITION_DONE)
    if condition in _CONDITIONS:
        return common.Dependency(job_id=job, condition=_CONDITIONS[condition])
    if condition.startswith("error<="):
        value = condition[len("error<="):]
        try:
            error = float(value[:-1]) / 100 if value.endswith("%") else float(value)
        except ValueError:
            raise InvalidArgument(f"after {text!r}: expected error<=N% or error<=FRACTION") from None
        return common.Dependency(job_id=job, condition=common.DEPENDENCY_CONDITION_ERROR_AT_MOST, max_error=error)
    raise InvalidArgument(f"after {text!r}: unknown condition {condition!r} (done, failed, ended, approved, "
                          "error<=N%)")


def job_policy(*, after: Iterable[str] = (), on_dependency_failure: str = "fail", require_tags: Iterable[str] = (),
               prefer_tags: Iterable[str] = (), audit_require_tags: Iterable[str] = (),
               max_workers: Optional[int] = None, share_weight: float = 0.0, max_unit_failures: Optional[int] = None,
               max_worker_failures: Optional[int] = None, unit_time_limit: Optional[float] = None,
               on_failure: str = "fail") -> "common.JobPolicy":
    dep_failure = {"fail": common.DEPENDENCY_FAILURE_FAIL, "wait": common.DEPENDENCY_FAILURE_WAIT}
    failure = {"fail": common.ON_FAILURE_FAIL, "pause": common.ON_FAILURE_PAUSE}
    if on_dependency_failure not in dep_failure:
        raise InvalidArgument(f"on_dependency_failure: expected 'fail' or 'wait', not {on_dependency_failure!r}")
    if on_failure not in failure:
        raise InvalidArgument(f"on_failure: expected 'fail' or 'pause', not {on_failure!r}")
    policy = common.JobPolicy(after=[dependency(a) for a in after], on_dependency_failure=dep_failure[on_dependency_failure],
                              require_tags=list(require_tags), prefer_tags=list(prefer_tags),
                              audit_require_tags=list(audit_require_tags), share_weight=share_weight,
                              on_failure=failure[on_failure])
    return _with(policy, max_workers=max_workers, max_unit_failures=max_unit_failures,
                 max_worker_failures=max_worker_failures, unit_time_limit_seconds=unit_time_limit)


def model_scene(model_file: str) -> dict:
    """The scene `lensfarm render MODEL` renders a model file with (scene/scene_loader.cpp,
    modelScene): the model at 1280x720, 64 samples per pixel, 4 bounces, its own camera and
    lights; an OBJ's faces without a material light grey."""
    ext = posixpath.splitext(model_file)[1].lower()
    kind = "obj" if ext == ".obj" else "usd" if ext.startswith(".usd") else "gltf"
    scene = {
        "format": "lensfarm-scene/1",
        "render": {"resolution": [1280, 720], "samples_per_pixel": 64, "max_bounces": 4},
        "shapes": [{"type": kind, "file": model_file}],
    }
    if ext == ".obj":
        scene["materials"] = {"default grey": {"type": "lambertian", "albedo": 0.7}}
        scene["shapes"][0]["fallback_material"] = "default grey"
    return scene


def connect(address: Optional[str] = None, **kwargs) -> Client:
    """Client(address, **kwargs), checked at once: raises Unavailable if the coordinator cannot be
    reached, Unauthenticated for a wrong token, IncompatibleCoordinator for another API."""
    client = Client(address, **kwargs)
    try:
        client.server_info()
    except BaseException:
        client.close()
        raise
    return client
