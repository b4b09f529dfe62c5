"""The files a scene references, found without rendering it, so a submission carries them.

A scene (the lensfarm-scene/1 JSON of docs/scene-format.md) names its files by paths relative to
itself: meshes, models, textures, lens prescriptions, skies, volume grids, aperture images. The
farm's loader is the judge of what it reads; here every string in the scene that names a
readable file beside it is taken, and so, in turn, are the files those name (a glTF's buffers and
images, an OBJ's material libraries, an MTL's texture maps, a USD layer's references, sublayers
and textures). Taking one file too many only costs
its upload; a file missed is refused by the coordinator naming it (FAILED_PRECONDITION or
INVALID_ARGUMENT), and can be given with ``submit(..., assets=...)``.

Paths are kept as the scene writes them, relative to the scene's folder, with "/" separators; a
path that leaves the folder ("..", absolute, a URL) is never taken: the farm refuses those.
"""

from __future__ import annotations

import json
import os
import posixpath
import struct
from pathlib import Path
from typing import Dict, Iterable, Iterator, Optional

from .errors import SceneError

# Files a scene may hold that name further files.
_GLTF = (".gltf",)
_GLB = (".glb",)
_OBJ = (".obj",)
_MTL = (".mtl",)
_USDA = (".usda", ".usd")
# MTL statements whose last argument is a texture file (Wavefront's, and the PBR extension's).
_MTL_MAPS = {
    "map_ka", "map_kd", "map_ks", "map_ke", "map_ns", "map_d", "map_bump", "bump", "disp", "decal", "refl",
    "map_pr", "map_pm", "map_ps", "map_norm", "norm", "map_tr", "map_kt",
}
# Files bigger than this are still taken, but never parsed for further names.
_MAX_PARSED_BYTES = 256 << 20


def _safe_relative(path: str) -> Optional[str]:
    """The path in the farm's form (relative, "/"), or None if it cannot be an asset's."""
    if not path or "\0" in path or "://" in path or path.startswith("data:"):
        return None
    p = path.replace("\\", "/")
    if p.startswith("/") or (len(p) > 1 and p[1] == ":"):
        return None
    norm = posixpath.normpath(p)
    if norm == "." or norm.startswith("../") or norm == "..":
        return None
    return p


def _strings(value) -> Iterator[str]:
    if isinstance(value, str):
        yield value
    elif isinstance(value, dict):
        for v in value.values():
            yield from _strings(v)
    elif isinstance(value, list):
        for v in value:
            yield from _strings(v)


def _gltf_uris(doc: dict) -> Iterator[str]:
    for key in ("buffers", "images"):
        for item in doc.get(key, []) or []:
            if isinstance(item, dict) and isinstance(item.get("uri"), str):
                uri = item["uri"]
                if not uri.startswith("data:"):
                    # glTF URIs are percent-encoded (RFC 3986).
                    from urllib.parse import unquote

                    yield unquote(uri)


def _glb_json(data: bytes) -> Optional[dict]:
    if len(data) < 20 or data[:4] != b"glTF":
        return None
    length, kind = struct.unpack_from("<II", data, 12)
    if kind != 0x4E4F534A or 20 + length > len(data):
        return None
    try:
        return json.loads(data[20:20 + length].decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError):
        return None


def _named_by(name: str, data: bytes) -> Iterator[str]:
    """Paths (relative to the file itself) that the file `name` refers to."""
    ext = posixpath.splitext(name)[1].lower()
    if len(data) > _MAX_PARSED_BYTES:
        return
    if ext in _GLTF:
        try:
            doc = json.loads(data.decode("utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError):
            return
        if isinstance(doc, dict):
            yield from _gltf_uris(doc)
    elif ext in _GLB:
        doc = _glb_json(data)
        if isinstance(doc, dict):
            yield from _gltf_uris(doc)
    elif ext in _USDA and data.startswith(b"#usda"):
        # Asset paths (@file@): references, sublayers, textures.
        import re

        for match in re.finditer(rb"@([^@\n]+)@", data):
            yield match.group(1).decode("utf-8", errors="replace")
    elif ext in _OBJ or ext in _MTL:
        text = data.decode("utf-8", errors="replace")
        for line in text.splitlines():
            parts = line.strip().split()
            if not parts:
                continue
            key = parts[0].lower()
            if ext in _OBJ and key == "mtllib":
                rest = line.strip()[len(parts[0]):].strip()
                yield rest  # one name with spaces ...
                yield from parts[1:]  # ... or several names
            elif ext in _MTL and key in _MTL_MAPS and len(parts) > 1:
                yield parts[-1]  # options (-bm 1, -clamp on, ...) come first
                yield line.strip()[len(parts[0]):].strip()  # a name with spaces


def find_assets(scene: dict, folder: Path) -> Dict[str, Path]:
    """Every file the scene (its JSON as a dict) may read, found from `folder` (the scene's):
    {path as the loader asks for it: file on disk}. A file reached by two spellings ("a/b.png",
    "a/./b.png") is listed under both: the farm looks an asset up by the spelling it reads."""
    found: Dict[str, Path] = {}
    parsed = set()
    root = folder.resolve()

    def spellings(rel: str, base: str) -> Iterator[str]:
        for r in dict.fromkeys([rel, rel.replace("\\", "/")]):
            key = posixpath.join(base, r) if base else r
            yield key
            yield posixpath.normpath(key)

    def take(rel: str, base: str) -> None:
        for key in dict.fromkeys(spellings(rel, base)):
            safe = _safe_relative(key)
            if safe is None or key in found:
                continue
            path = root / posixpath.normpath(safe)
            try:
                resolved = path.resolve()
                if not path.is_file() or root not in resolved.parents:
                    continue
            except OSError:
                continue
            found[key] = path
            if resolved in parsed:
                continue
            parsed.add(resolved)
            try:
                data = path.read_bytes()
            except OSError as e:
                raise SceneError(f"{path}: cannot read: {e.strerror}") from None
            for name in _named_by(key, data):
                take(name, posixpath.dirname(key))

    for s in list(_strings(scene)):
        take(s, "")
    return found


def read_assets(files: Dict[str, Path]) -> Dict[str, bytes]:
    out = {}
    for rel, path in files.items():
        try:
            out[rel] = Path(path).read_bytes()
        except OSError as e:
            raise SceneError(f"asset {rel} ({path}): cannot read: {e.strerror}") from None
    return out


def iter_chunks(data: bytes, size: int = 1 << 20) -> Iterable[bytes]:
    for i in range(0, max(len(data), 1), size):
        yield data[i:i + size]


def scene_folder_of(path: os.PathLike) -> Path:
    return Path(path).resolve().parent
