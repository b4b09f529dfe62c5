"""Blender's quantities as lensfarm's (docs/blender.md "What is carried"), with no bpy in sight, so
the numbers can be checked on their own (tests/blender/addon_checks.py).

Coordinates: Blender is Z-up, right-handed; glTF and the lensfarm scene the add-on writes are
Y-up (what Blender's glTF exporter writes with +Y up): (x, y, z) -> (x, z, -y).

Light units, as Cycles 3.4 renders them (each checked against Cycles in tests/blender):
  * point and spot lamp, power P W, colour c: radiant intensity c P / (4 pi) W/sr (a spot is a
    point lamp cut by its cone, not concentrated into it);
  * spot size S, blend b: lensfarm's cone_angle S/2 and falloff_start acos(cos(S/2) + b (1 - cos(S/2))),
    Cycles' smoothstep in the cosine, exactly;
  * sun, strength E W/m^2: irradiance c E, angular diameter its angle;
  * area lamp, power P W over area A: radiance c P / (4 A), from its -Z face, unseen by the camera
    (measured: pi/4 of a Lambertian emitter of power P, within 0.3 %);
  * emission shader strength S: radiance c S (Blender's glTF exporter writes it unconverted);
  * world background colour c, strength S: environment radiance c S.
"""

import math

LUMINOUS_EFFICACY = 683.0  # lm/W: Blender's glTF exporter's factor for lamps (its 'SPEC' mode)


def y_up(v):
    """A Blender (Z-up) point or direction in the Y-up frame of glTF and the written scene."""
    return [float(v[0]), float(v[2]), -float(v[1])]


def point_intensity(colour, watts):
    return [c * watts / (4.0 * math.pi) for c in colour]


def spot_cone(size_radians, blend):
    """(cone_angle, falloff_start) in degrees for a Cycles spot of full angle `size` and `blend`."""
    half = size_radians / 2.0
    cos_half = math.cos(half)
    cos_start = min(1.0, cos_half + blend * (1.0 - cos_half))
    cone = math.degrees(half)
    return min(cone, 90.0), min(math.degrees(math.acos(cos_start)), min(cone, 90.0))


def area_radiance(colour, watts, area):
    return [c * watts / (4.0 * area) for c in colour]


def sun_irradiance(colour, strength):
    return [c * strength for c in colour]


def clean(value, digits=9):
    """Numbers as short as they are exact enough (JSON stays readable)."""
    if isinstance(value, (list, tuple)):
        return [clean(v, digits) for v in value]
    if isinstance(value, float):
        r = float(f"{value:.{digits}g}")
        return 0.0 if r == 0 else r
    return value


def thin_lens(lens_mm, sensor_mm, fit_horizontal, width, height, f_stop, focus_distance, unit_scale=1.0):
    """lensfarm's thin_lens fields for Blender's perspective camera with depth of field.

    Cycles keeps the field of view of `lens_mm` on `sensor_mm` whatever the focus (its lens is a
    pinhole whose rays are bent to the focal plane); lensfarm's thin lens moves its sensor back
    to S2 = f S1 / (S1 - f) when focused at S1, and sees less. Here the sensor is scaled by S2 / f,
    so the view at the focal plane, and the blur of each point there (aperture radius
    f / (2 N) for both), are Cycles' exactly.
    """
    f = lens_mm / 1000.0 / unit_scale
    s1 = focus_distance
    s2 = f * s1 / (s1 - f)
    along_fit = sensor_mm / 1000.0 / unit_scale * s2 / f
    sensor_width = along_fit if fit_horizontal else along_fit * width / height
    return {"focal_length": f, "sensor_width": sensor_width, "sensor_height": sensor_width * height / width,
            "f_number": f_stop, "focus_distance": s1}


def angle_of_view(lens_mm, sensor_mm):
    return math.degrees(2.0 * math.atan(sensor_mm / (2.0 * lens_mm)))


def sensor_fit_horizontal(fit, width, height):
    """Whether Blender's sensor size spans the image's width ('AUTO': the larger side)."""
    if fit == "HORIZONTAL":
        return True
    if fit == "VERTICAL":
        return False
    return width >= height
