"""Errors the library raises: one class per gRPC status the coordinator answers with, each
carrying that status, plus the library's own (a scene it cannot read, a coordinator it cannot
work with, a job that ended badly).

Every error is a :class:`LensfarmError`; catching that catches them all. The coordinator's message
(``details``) names the field, job or asset at fault, e.g. ``InvalidArgument("scene.json: render.
samples_per_pixel: expected ...")``.
"""

from __future__ import annotations

from typing import Optional

import grpc


class LensfarmError(Exception):
    """Anything that went wrong. ``code`` is the gRPC status (None for the library's own errors),
    ``details`` the coordinator's message, ``rpc`` the call that failed."""

    code: Optional[grpc.StatusCode] = None

    def __init__(self, details: str, rpc: str = "", code: Optional[grpc.StatusCode] = None):
        # The coordinator's messages often start with the call already ("GetJob: ...").
        super().__init__(f"{rpc}: {details}" if rpc and not details.startswith(f"{rpc}:") else details)
        self.details = details
        self.rpc = rpc
        if code is not None:
            self.code = code


class InvalidArgument(LensfarmError):
    """The request (a scene field, a flag, an id's form) is wrong; details name it."""

    code = grpc.StatusCode.INVALID_ARGUMENT


class NotFound(LensfarmError):
    """No such job (or frame, or asset)."""

    code = grpc.StatusCode.NOT_FOUND


class AlreadyExists(LensfarmError):
    code = grpc.StatusCode.ALREADY_EXISTS


class PermissionDenied(LensfarmError):
    """The caller's role may not do this (a viewer writing, a submitter acting on another's job)."""

    code = grpc.StatusCode.PERMISSION_DENIED


class Unauthenticated(LensfarmError):
    """A missing, wrong or expired token."""

    code = grpc.StatusCode.UNAUTHENTICATED


class FailedPrecondition(LensfarmError):
    """Not now: assets not uploaded, a job that has ended, an image not rendered yet."""

    code = grpc.StatusCode.FAILED_PRECONDITION


class ResourceExhausted(LensfarmError):
    """A quota or limit: jobs per owner, asset bytes, memory, downloads at once."""

    code = grpc.StatusCode.RESOURCE_EXHAUSTED


class Unavailable(LensfarmError):
    """The coordinator cannot be reached (or is shutting down)."""

    code = grpc.StatusCode.UNAVAILABLE


class DeadlineExceeded(LensfarmError):
    """A call or a wait took longer than its timeout."""

    code = grpc.StatusCode.DEADLINE_EXCEEDED


class Unimplemented(LensfarmError):
    """The coordinator does not know the call (it is older than the library)."""

    code = grpc.StatusCode.UNIMPLEMENTED


class Internal(LensfarmError):
    code = grpc.StatusCode.INTERNAL


class Cancelled(LensfarmError):
    code = grpc.StatusCode.CANCELLED


class IncompatibleCoordinator(LensfarmError):
    """The coordinator serves another API than this library speaks (GetServerInfo)."""


class SceneError(LensfarmError):
    """A scene file or one of its assets cannot be read here, before anything is sent."""


class JobFailed(LensfarmError):
    """wait(): the job failed; ``status`` is its last JobStatus (``status.error`` says why)."""

    def __init__(self, details: str, status=None):
        super().__init__(details)
        self.status = status


class JobCancelled(JobFailed):
    """wait(): the job was cancelled (by someone, or by its dependency policy)."""


_BY_CODE = {
    cls.code: cls
    for cls in (InvalidArgument, NotFound, AlreadyExists, PermissionDenied, Unauthenticated, FailedPrecondition,
                ResourceExhausted, Unavailable, DeadlineExceeded, Unimplemented, Internal, Cancelled)
}


def from_rpc_error(error: grpc.RpcError, rpc: str) -> LensfarmError:
    """The typed error for a failed call (LensfarmError with the code for statuses without a class)."""
    code = error.code() if hasattr(error, "code") else grpc.StatusCode.UNKNOWN
    details = (error.details() if hasattr(error, "details") else None) or str(code)
    cls = _BY_CODE.get(code)
    if cls is None:
        return LensfarmError(details, rpc, code)
    return cls(details, rpc)
