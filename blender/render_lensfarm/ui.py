"""The add-on's face in Blender: its preferences (the coordinator and the token, kept in Blender's
user preferences, never in a .blend), the job settings of each scene, the panel in Render
properties, and the operators (Submit, Cancel, Load Result)."""

import os
import tempfile

import bpy
from bpy.props import BoolProperty, CollectionProperty, EnumProperty, FloatProperty, IntProperty, StringProperty

from . import export, farm

ADDON = __package__


def preferences(context):
    return context.preferences.addons[ADDON].preferences


class LensfarmPreferences(bpy.types.AddonPreferences):
    bl_idname = ADDON

    address: StringProperty(name="Coordinator", default="127.0.0.1:7878",
                            description="The coordinator's gRPC address, HOST:PORT")
    token: StringProperty(name="Token", subtype="PASSWORD", default="",
                          description="Your lensfarm token (kept in Blender's preferences, never in the .blend)")
    token_file: StringProperty(name="Token File", subtype="FILE_PATH", default="",
                               description="Or a file holding it (chmod 600); else $LENSFARM_TOKEN")
    tls_ca: StringProperty(name="TLS CA", subtype="FILE_PATH", default="",
                           description="PEM CA certificate of a coordinator that serves TLS")
    lensfarm_program: StringProperty(name="lensfarm Program", subtype="FILE_PATH", default="",
                                     description="The lensfarm command, for Denoise (empty: found on PATH)")

    def draw(self, context):
        layout = self.layout
        for name in ("address", "token", "token_file", "tls_ca", "lensfarm_program"):
            layout.prop(self, name)


class LensfarmNote(bpy.types.PropertyGroup):
    text: StringProperty()


class LensfarmSettings(bpy.types.PropertyGroup):
    samples_from: EnumProperty(name="Samples", items=[("CYCLES", "Cycles' Samples", "Render > Sampling's samples"),
                                                      ("CUSTOM", "Custom", "The number below")], default="CYCLES")
    samples: IntProperty(name="Samples", default=128, min=1, max=1 << 24)
    target_error: FloatProperty(name="Target Error %", default=0.0, min=0.0, max=99.0,
                                description="Stop at this estimated relative RMSE (percent); 0: at the samples")
    deadline: FloatProperty(name="Deadline (s)", default=0.0, min=0.0,
                            description="Stop this many seconds after submission; 0: none")
    priority: IntProperty(name="Priority", default=0, description="Higher runs first")
    frames: EnumProperty(name="Frames", items=[("STILL", "Current Frame", "A still of the current frame"),
                                               ("SCENE", "Scene Range", "The scene's frame range"),
                                               ("CUSTOM", "Custom Range", "The range below")], default="STILL")
    frame_first: IntProperty(name="First", default=1)
    frame_last: IntProperty(name="Last", default=1)
    frame_step: IntProperty(name="Step", default=1, min=1)
    tile_size: IntProperty(name="Tile Size", default=0, min=0, max=16384, description="0: the farm chooses")
    aov_albedo: BoolProperty(name="Albedo", default=False)
    aov_normal: BoolProperty(name="Normal", default=False)
    aov_depth: BoolProperty(name="Depth", default=False)
    aov_variance: BoolProperty(name="Variance", default=False)
    denoise: BoolProperty(name="Denoise", default=False,
                          description="Render albedo and normal layers and denoise the image on this machine")
    output_dir: StringProperty(name="Output", subtype="DIR_PATH", default="//lensfarm/",
                               description="Where the images are saved (// is the .blend's folder)")
    # What the last job did (shown in the panel).
    job_id: StringProperty(name="Job")
    state: StringProperty(name="State")
    status_line: StringProperty(name="Status")
    progress: FloatProperty(name="Progress", min=0.0, max=1.0, subtype="FACTOR")
    error: StringProperty(name="Error")
    export_folder: StringProperty(name="Exported Scene", subtype="DIR_PATH")
    images: StringProperty(name="Images")  # the loaded EXRs, ";"-separated
    farm_images: StringProperty(name="Farm Images")  # the farm's EXRs as downloaded (before denoising)
    notes: CollectionProperty(type=LensfarmNote)


_runs = {}  # scene name -> farm.Run in progress


def _connection(context) -> farm.Connection:
    p = preferences(context)
    return farm.Connection(address=p.address, token=p.token or None, token_file=bpy.path.abspath(p.token_file) or None,
                           tls_ca=bpy.path.abspath(p.tls_ca) or None)


def _folder(scene, settings) -> str:
    base = settings.output_dir
    if base.startswith("//") and not bpy.data.filepath:
        base = os.path.join(tempfile.gettempdir(), "lensfarm")
    folder = bpy.path.abspath(base)
    os.makedirs(folder, exist_ok=True)
    return tempfile.mkdtemp(prefix=f"{bpy.path.clean_name(scene.name)}-", dir=folder)


def _request(context, job, folder) -> farm.Request:
    s = context.scene.lensfarm
    name = bpy.path.display_name_from_filepath(bpy.data.filepath) or context.scene.name
    return farm.Request(job=job, folder=folder, name=f"{name}.json", priority=s.priority, denoise=s.denoise,
                        lensfarm_program=bpy.path.abspath(preferences(context).lensfarm_program))


def _show_status(settings, status):
    settings.job_id = status.job_id
    settings.state = farm.lensfarm.state_name(status)
    settings.status_line = farm.lensfarm.describe(status)
    settings.progress = min(1.0, max(0.0, status.progress.progress_fraction))


def load_images(settings, outcome) -> list:
    """The farm's EXR in Blender's image editor: a still as an image, an animation as a sequence."""
    paths = outcome.denoised or outcome.images
    if not paths:
        return []
    image = bpy.data.images.load(paths[0], check_existing=False)
    image.name = f"lensfarm {outcome.job_id}"
    if len(paths) > 1:
        image.source = "SEQUENCE"
    for window in getattr(bpy.context.window_manager, "windows", []):
        for area in window.screen.areas:
            if area.type == "IMAGE_EDITOR":
                area.spaces.active.image = image
                if len(paths) > 1:
                    user = area.spaces.active.image_user
                    user.frame_start, user.frame_duration = outcome.frames[0], len(paths)
                    user.frame_offset = outcome.frames[0] - 1
    settings.images = ";".join(paths)
    settings.farm_images = ";".join(outcome.images)
    return [image]


def _finish(settings, outcome):
    if outcome.error:
        settings.error = outcome.error
        return
    load_images(settings, outcome)


def _redraw():
    for window in getattr(bpy.context.window_manager, "windows", []):
        for area in window.screen.areas:
            if area.type in ("PROPERTIES", "IMAGE_EDITOR"):
                area.tag_redraw()


def _poll_runs():
    """bpy.app.timers: the runs' reports, on Blender's own thread."""
    for scene_name, run in list(_runs.items()):
        scene = bpy.data.scenes.get(scene_name)
        while not run.events.empty():
            kind, value = run.events.get()
            if scene is None:
                continue
            settings = scene.lensfarm
            if kind in ("submitted", "status"):
                _show_status(settings, value)
            elif kind == "log":
                settings.notes.add().text = value
            elif kind == "end":
                _finish(settings, value)
                del _runs[scene_name]
        _redraw()
    return 0.5 if _runs else None


class LENSFARM_OT_submit(bpy.types.Operator):
    """Render this scene on the lensfarm coordinator of the add-on's preferences"""

    bl_idname = "lensfarm.submit"
    bl_label = "Submit to lensfarm"
    bl_options = {"REGISTER"}

    wait: BoolProperty(name="Wait", default=False, description="Block until the image is back (scripts)")

    _job = None
    _folder = ""

    def _export(self, context):
        settings = context.scene.lensfarm
        settings.error = ""
        settings.notes.clear()
        folder = _folder(context.scene, settings)
        job = export.build_job(context, settings, folder)
        settings.export_folder = folder
        for note in job.notes:
            settings.notes.add().text = note
        return job, folder

    def invoke(self, context, event):
        try:
            self._job, self._folder = self._export(context)
        except (export.ExportError, RuntimeError) as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        if self._job.notes:
            return context.window_manager.invoke_props_dialog(self, width=640)
        return self.execute(context)

    def draw(self, context):
        layout = self.layout
        layout.label(text="Not carried to lensfarm (submit anyway?):")
        col = layout.column(align=True)
        for note in self._job.notes:
            col.label(text=note, icon="DOT")

    def execute(self, context):
        settings = context.scene.lensfarm
        if context.scene.name in _runs:
            self.report({"ERROR"}, f"{settings.job_id or 'a job'} of this scene is still running")
            return {"CANCELLED"}
        try:
            job, folder = (self._job, self._folder) if self._job is not None else self._export(context)
        except (export.ExportError, RuntimeError) as e:
            settings.error = str(e)
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        for note in job.notes:
            self.report({"WARNING"}, f"lensfarm: {note}")
        settings.job_id, settings.state, settings.status_line, settings.progress = "", "submitting", "", 0.0
        connection, request = _connection(context), _request(context, job, folder)
        if self.wait or bpy.app.background:
            outcome = farm.run(connection, request,
                               lambda kind, value: _show_status(settings, value) if kind in ("submitted", "status")
                               else (print(f"lensfarm: {value}") if kind == "log" else None))
            _finish(settings, outcome)
            if outcome.error:
                self.report({"ERROR"}, outcome.error)
                return {"CANCELLED"}
            self.report({"INFO"}, f"lensfarm: {outcome.job_id} done, {len(outcome.images)} image(s) loaded")
            return {"FINISHED"}
        _runs[context.scene.name] = farm.Run(connection, request)
        if not bpy.app.timers.is_registered(_poll_runs):
            bpy.app.timers.register(_poll_runs, first_interval=0.2)
        self.report({"INFO"}, "lensfarm: submitting")
        return {"FINISHED"}


class LENSFARM_OT_cancel(bpy.types.Operator):
    """Cancel this scene's lensfarm job (what was rendered stays and is loaded)"""

    bl_idname = "lensfarm.cancel"
    bl_label = "Cancel lensfarm Job"

    def execute(self, context):
        run = _runs.get(context.scene.name)
        if run is not None:
            run.cancel()
            return {"FINISHED"}
        settings = context.scene.lensfarm
        if not settings.job_id:
            self.report({"ERROR"}, "no lensfarm job to cancel")
            return {"CANCELLED"}
        try:
            with farm.connect(_connection(context)) as f:
                _show_status(settings, f.cancel(settings.job_id))
        except farm.lensfarm.LensfarmError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        return {"FINISHED"}


class LENSFARM_OT_load(bpy.types.Operator):
    """Load this scene's last lensfarm image again"""

    bl_idname = "lensfarm.load_result"
    bl_label = "Load lensfarm Result"

    def execute(self, context):
        settings = context.scene.lensfarm
        paths = [p for p in settings.images.split(";") if p]
        if not paths or not all(os.path.exists(p) for p in paths):
            self.report({"ERROR"}, "no lensfarm image on disk for this scene")
            return {"CANCELLED"}
        outcome = farm.Outcome(job_id=settings.job_id, images=paths,
                               frames=list(range(1, len(paths) + 1)))
        load_images(settings, outcome)
        return {"FINISHED"}


class LENSFARM_PT_render(bpy.types.Panel):
    bl_label = "Render on lensfarm"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "render"

    def draw(self, context):
        layout = self.layout
        s = context.scene.lensfarm
        p = preferences(context)
        layout.use_property_split = True
        layout.use_property_decorate = False
        layout.prop(p, "address")
        col = layout.column()
        col.prop(s, "samples_from")
        if s.samples_from == "CUSTOM":
            col.prop(s, "samples")
        col.prop(s, "target_error")
        col.prop(s, "deadline")
        col.prop(s, "priority")
        col = layout.column()
        col.prop(s, "frames")
        if s.frames == "CUSTOM":
            row = col.row(align=True)
            row.prop(s, "frame_first")
            row.prop(s, "frame_last")
            row.prop(s, "frame_step")
        col.prop(s, "tile_size")
        col = layout.column(heading="Layers")
        for name in ("aov_albedo", "aov_normal", "aov_depth", "aov_variance", "denoise"):
            col.prop(s, name)
        layout.prop(s, "output_dir")
        row = layout.row(align=True)
        row.scale_y = 1.4
        row.operator("lensfarm.submit", icon="RENDER_STILL")
        row.operator("lensfarm.cancel", text="", icon="CANCEL")
        row.operator("lensfarm.load_result", text="", icon="IMAGE_DATA")
        if s.job_id or s.state:
            box = layout.box()
            box.label(text=s.status_line or s.state, icon="INFO")
            box.prop(s, "progress", text="Progress", slider=True)
        if s.error:
            box = layout.box()
            box.alert = True
            box.label(text=s.error, icon="ERROR")
        if len(s.notes):
            box = layout.box()
            box.label(text="Not carried:", icon="QUESTION")
            col = box.column(align=True)
            for note in s.notes:
                col.label(text=note.text)


CLASSES = (LensfarmPreferences, LensfarmNote, LensfarmSettings, LENSFARM_OT_submit, LENSFARM_OT_cancel,
           LENSFARM_OT_load, LENSFARM_PT_render)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.Scene.lensfarm = bpy.props.PointerProperty(type=LensfarmSettings)


def unregister():
    del bpy.types.Scene.lensfarm
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
