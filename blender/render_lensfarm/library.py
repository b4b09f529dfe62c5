"""The Python library `lensfarm` (python/lensfarm, docs/python.md), which the add-on talks to the farm
through: the copy bundled in the add-on's vendor/ folder (the zip built with the project carries the
library it was built with), else one installed for the system Python (`cmake --install`).
Blender 3.4 on Debian runs on the system Python 3.11, where python3-grpcio and python3-protobuf
import."""

import importlib
import os
import sys

VENDOR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "vendor")


class Missing(ImportError):
    pass


def load():
    if os.path.isdir(os.path.join(VENDOR, "lensfarm")) and VENDOR not in sys.path:
        sys.path.insert(0, VENDOR)
    try:
        return importlib.import_module("lensfarm")
    except ImportError as e:
        raise Missing(f"the lensfarm Python library cannot be imported ({e}): install python3-grpcio and "
                      "python3-protobuf (apt-get install python3-grpcio python3-protobuf)") from e
