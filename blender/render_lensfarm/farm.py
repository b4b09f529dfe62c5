"""Submitting an exported job to the farm and bringing its image back, off Blender's UI thread.

A Run does the farm's part in a thread (upload what the coordinator lacks, submit, follow the job
through WatchJob, download the EXR of the still or of every frame, denoise it if asked) and puts
what happens into a queue; the UI side (ui.py) drains the queue from a bpy.app.timers callback and
touches Blender's data only there. A script, or Blender in background mode, calls run() directly
and waits.
"""

import os
import queue
import shutil
import subprocess
import threading
import time
from dataclasses import dataclass, field
from typing import List, Optional

from . import library

lensfarm = library.load()


@dataclass
class Connection:
    address: str
    token: Optional[str] = None
    token_file: Optional[str] = None
    tls_ca: Optional[str] = None


@dataclass
class Request:
    job: object                  # export.Job
    folder: str                  # where the exported scene is and the images go
    name: str                    # the job's scene name
    priority: int = 0
    denoise: bool = False
    lensfarm_program: str = ""   # for the denoiser; "" finds `lensfarm` on PATH


@dataclass
class Outcome:
    job_id: str = ""
    images: List[str] = field(default_factory=list)   # EXR paths: the still, or each frame in order
    frames: List[int] = field(default_factory=list)
    denoised: List[str] = field(default_factory=list)
    error: str = ""


def connect(c: Connection):
    kwargs = {"tls_ca": c.tls_ca or None}
    if c.token:
        kwargs["token"] = c.token
    elif c.token_file:
        kwargs["token_file"] = c.token_file
    return lensfarm.connect(c.address, **kwargs)


def run(c: Connection, r: Request, report=lambda kind, value: None, cancelled=lambda: False) -> Outcome:
    """Does the whole job; report("status", JobStatus) at every change, report("log", text)."""
    out = Outcome()
    try:
        with connect(c) as farm:
            submitted = farm.submit(r.job.scene, assets=r.job.assets, name=r.name, priority=r.priority,
                                    frames=r.job.frames)
            out.job_id = submitted.job_id
            report("submitted", submitted)
            final = None
            for status in farm.watch(submitted):
                final = status
                report("status", status)
                if cancelled():
                    farm.cancel(submitted)
            state = lensfarm.state_name(final)
            if state == "failed":
                out.error = f"{final.job_id} failed: {final.error}"
                return out
            if state == "cancelled" and final.progress.units_done == 0:
                out.error = f"{final.job_id} was cancelled before any sample was rendered"
                return out
            if r.job.frames:
                for frame in final.frames:
                    if not frame.complete:
                        continue
                    path = os.path.join(r.folder, f"{final.job_id}_{frame.frame:04d}.exr")
                    farm.download(final, path, frame=frame.frame)
                    out.images.append(path)
                    out.frames.append(frame.frame)
            else:
                path = os.path.join(r.folder, f"{final.job_id}.exr")
                farm.download(final, path)
                out.images.append(path)
            if r.denoise:
                out.denoised = denoise(out.images, r.lensfarm_program, report)
    except lensfarm.LensfarmError as e:
        out.error = str(e)
    return out


def denoise(images, program, report) -> List[str]:
    program = program or shutil.which("lensfarm") or ""
    if not program or not os.path.exists(program):
        report("log", "Denoise: the lensfarm program is not on this machine (Preferences > lensfarm program); "
                      "the noisy image is loaded")
        return []
    done = []
    for path in images:
        target = path[:-len(".exr")] + "_denoised.exr"
        result = subprocess.run([program, "denoise", path, "-o", target], capture_output=True, text=True)
        if result.returncode != 0:
            report("log", f"Denoise {os.path.basename(path)}: {result.stderr.strip()}")
            return done
        done.append(target)
    return done


class Run:
    """run() in a thread; its reports in `events` for the UI thread."""

    def __init__(self, c: Connection, r: Request):
        self.events: "queue.Queue" = queue.Queue()
        self.outcome: Optional[Outcome] = None
        self.started = time.monotonic()
        self._cancel = threading.Event()
        self._thread = threading.Thread(target=self._main, args=(c, r), daemon=True, name="lensfarm job")
        self._thread.start()

    def _main(self, c, r):
        self.outcome = run(c, r, lambda kind, value: self.events.put((kind, value)), self._cancel.is_set)
        self.events.put(("end", self.outcome))

    def cancel(self):
        self._cancel.set()

    def alive(self) -> bool:
        return self._thread.is_alive()
