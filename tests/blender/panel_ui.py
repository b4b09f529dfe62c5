"""The add-on in Blender's real user interface (under Xvfb), the way a user meets it: the default
scene (cube, lamp, camera) opened in a Blender window, the Render properties shown, Submit pressed
(the operator run as the button runs it: no waiting) while Blender's event loop goes on, and the
job followed by the add-on's timer until its image is in Blender. Then the panel is captured.

    xvfb-run -a -s "-screen 0 1200x1400x24" blender --factory-startup scene.blend --python \
        tests/blender/panel_ui.py -- --zip render_lensfarm.zip --coordinator HOST:PORT \
        --out DIR [--token-file F]

Exits 0 when the job ended done and its image was loaded while the UI kept running (the timer
fired in between), writing DIR/panel.png (the screenshot in README.md and docs/blender.md);
exits 1 otherwise, saying why.
"""

import os
import sys
import time

import addon_utils
import bpy

argv = sys.argv[sys.argv.index("--") + 1:]


def arg(name, default=None):
    return argv[argv.index(name) + 1] if name in argv else default


ZIP, COORDINATOR, OUT, TOKEN_FILE = arg("--zip"), arg("--coordinator"), arg("--out"), arg("--token-file", "")
state = {"ticks": 0, "while_running": 0, "started": time.monotonic()}


def fail(why):
    print(f"FAILED: {why}", flush=True)
    os._exit(1)


def properties_area():
    win = bpy.context.window_manager.windows[0]
    return win, max((a for a in win.screen.areas if a.type == "PROPERTIES"), key=lambda a: a.width * a.height)


def setup():
    bpy.ops.preferences.addon_install(filepath=ZIP)
    addon_utils.enable("render_lensfarm", default_set=True)
    prefs = bpy.context.preferences.addons["render_lensfarm"].preferences
    prefs.address, prefs.token_file = COORDINATOR, TOKEN_FILE
    s = bpy.context.scene
    s.render.engine = "CYCLES"
    s.render.resolution_x, s.render.resolution_y, s.render.resolution_percentage = 480, 270, 100
    s.cycles.samples = 64
    s.lensfarm.target_error = 3.0
    win = bpy.context.window_manager.windows[0]
    # The largest area (the 3D view) becomes the Properties editor, on the Render tab.
    big = max(win.screen.areas, key=lambda a: a.width * a.height)
    big.type = "PROPERTIES"
    bpy.app.timers.register(submit, first_interval=1.0)


def submit():
    win, area = properties_area()
    area.spaces.active.context = "RENDER"
    result = bpy.ops.lensfarm.submit("EXEC_DEFAULT")  # as the button runs it: no waiting
    if result != {"FINISHED"}:
        fail(f"submit: {result} {bpy.context.scene.lensfarm.error}")
    bpy.app.timers.register(follow, first_interval=0.1)


def follow():
    """Runs on Blender's event loop while the job renders: the UI is not blocked."""
    st = bpy.context.scene.lensfarm
    state["ticks"] += 1
    if st.state in ("submitting", "queued", "running"):
        state["while_running"] += 1
    if st.error:
        fail(f"the job: {st.error}")
    if not st.images:
        if time.monotonic() - state["started"] > 300:
            fail(f"no image after 300 s ({st.status_line})")
        return 0.2
    if st.state != "done" or bpy.data.images.get(f"lensfarm {st.job_id}") is None:
        fail(f"state {st.state}, images {[i.name for i in bpy.data.images]}")
    if state["while_running"] == 0:
        fail("the UI's timer never ran while the job was in flight")
    win, area = properties_area()
    region = next(r for r in area.regions if r.type == "WINDOW")
    with bpy.context.temp_override(window=win, screen=win.screen, area=area, region=region):
        for _ in range(60):  # to the end of the Render tab, where the panel is
            bpy.ops.view2d.scroll_down(deltay=100)
    bpy.app.timers.register(capture, first_interval=1.0)
    return None


def capture():
    win, area = properties_area()
    os.makedirs(OUT, exist_ok=True)
    with bpy.context.temp_override(window=win, screen=win.screen, area=area):
        bpy.ops.screen.screenshot_area(filepath=os.path.join(OUT, "panel.png"))
    st = bpy.context.scene.lensfarm
    print(f"PASSED: {st.status_line}; the timer ran {state['while_running']} time(s) while the job was in flight",
          flush=True)
    bpy.ops.wm.quit_blender()


bpy.app.timers.register(setup, first_interval=1.0)
