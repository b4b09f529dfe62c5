"""lensfarm: submit scenes to a lensfarm coordinator, follow them, download their images.

A pure-Python client of the coordinator's gRPC ClientService (proto/lensfarm/v1), over Debian's
python3-grpcio and python3-protobuf; the lensfarm.v1 stubs are generated from proto/ when the
project is built. docs/python.md has the guide and examples.
"""

from ._version import RENDERER_VERSION, __version__
from .client import API, Client, VersionWarning, connect, dependency, describe, job_policy, render_overrides, state_name
from .errors import (AlreadyExists, Cancelled, DeadlineExceeded, FailedPrecondition, IncompatibleCoordinator,
                     Internal, InvalidArgument, JobCancelled, JobFailed, LensfarmError, NotFound, PermissionDenied,
                     ResourceExhausted, SceneError, Unauthenticated, Unavailable, Unimplemented)
from .v1 import client_service_pb2 as messages
from .v1 import common_pb2 as common_messages

__all__ = [
    "API", "Client", "connect", "describe", "state_name", "dependency", "job_policy", "render_overrides",
    "VersionWarning", "RENDERER_VERSION", "__version__", "messages", "common_messages",
    "LensfarmError", "InvalidArgument", "NotFound", "AlreadyExists", "PermissionDenied", "Unauthenticated",
    "FailedPrecondition", "ResourceExhausted", "Unavailable", "DeadlineExceeded", "Unimplemented", "Internal",
    "Cancelled", "IncompatibleCoordinator", "SceneError", "JobFailed", "JobCancelled",
]
