"""Packing the scene into the structs of kernels/types.h (their numpy mirrors are in raytrace/types.py):
the one place where host values become what the kernel reads."""
import math

import numpy as np

from . import mipmap, samplers, types


def camera_struct(camera, width, height):
    forward, right, up = camera.basis()
    tan_half = math.tan(math.radians(camera.fov_deg) / 2)
    c = np.zeros((), types.CAMERA)
    c["position"], c["forward"], c["right"], c["up"] = camera.position, forward, right, up
    c["scale_x"] = width / height * camera.focal_length * tan_half
    c["scale_y"] = camera.focal_length * tan_half
    c["focal_length"] = camera.focal_length
    return c


def rectangle_structs(rects):
    a = np.zeros(max(len(rects), 1), types.RECTANGLE)
    for s, r in zip(a, rects):
        s["center"], s["normal"], s["tangent"], s["bitangent"] = r.center, r.normal, r.tangent, r.bitangent
        s["half_x"], s["half_y"], s["material"] = r.size[0] / 2, r.size[1] / 2, r.material
    return a


def triangle_structs(tris):
    a = np.zeros(max(len(tris), 1), types.TRIANGLE)
    for s, t in zip(a, tris):
        v0, v1, v2 = t.vertices
        n = np.cross(v1 - v0, v2 - v1)
        s["v0"], s["v1"], s["v2"], s["normal"], s["material"] = v0, v1, v2, n / np.linalg.norm(n), t.material
    return a


DEFAULT_UV = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])  # uv = (b1, b2)


def _coordinate_system(n):
    """Two unit vectors completing the unit vector n to an orthonormal basis (Duff et al., JCGT 2017)."""
    sign = math.copysign(1.0, n[2])
    a = -1.0 / (sign + n[2])
    b = n[0] * n[1] * a
    return np.array([1 + sign * n[0] ** 2 * a, sign * b, -sign * n[0]]), np.array([b, sign + n[1] ** 2 * a, -n[1]])


def triangle_uv_frame(vertices, uv):
    """dp/du and dp/dv of the affine map from uv to the triangle (pbrt-v4 section 6.5.4), in float64. A
    degenerate uv mapping (all uvs on a line) gets an orthonormal pair in the triangle's plane instead."""
    uv = DEFAULT_UV if uv is None else np.asarray(uv, dtype=np.float64)
    v0, v1, v2 = vertices
    duv02, duv12, dp02, dp12 = uv[0] - uv[2], uv[1] - uv[2], v0 - v2, v1 - v2
    det = duv02[0] * duv12[1] - duv02[1] * duv12[0]
    if not abs(det) > 1e-9 * max(np.dot(duv02, duv02), np.dot(duv12, duv12)):
        n = np.cross(v1 - v0, v2 - v1)
        return _coordinate_system(n / np.linalg.norm(n))
    return (duv12[1] * dp02 - duv02[1] * dp12) / det, (duv02[0] * dp12 - duv12[0] * dp02) / det


def triangle_uv_structs(tris):
    a = np.zeros(max(len(tris), 1), types.TRIANGLE_UV)
    for s, t in zip(a, tris):
        dpdu, dpdv = triangle_uv_frame(t.vertices, t.uv)
        s["uv"] = (DEFAULT_UV if t.uv is None else t.uv).ravel()
        s["dpdu"], s["dpdv"], s["tangent"] = dpdu, dpdv, dpdu / np.linalg.norm(dpdu)
    return a


def ellipsoid_structs(ells):
    a = np.zeros(max(len(ells), 1), types.ELLIPSOID)
    for s, e in zip(a, ells):
        s["center"], s["material"] = e.center, e.material
        s["world_to_unit"] = np.linalg.inv(e.matrix).ravel()  # float64 inverse, rounded once
        s["unit_to_world"] = e.matrix.ravel()
    return a


def light_structs(lights):
    a = np.zeros(max(len(lights), 1), types.LIGHT)  # a scene without lights (the API allows one) gets a dummy
    a["shape"] = rectangle_structs(lights)
    for s, light in zip(a, lights):
        s["colour"] = light.colour
    return a


def material_structs(materials):
    a = np.zeros(len(materials), types.MATERIAL)
    for s, m in zip(a, materials):
        s["colour"], s["shininess"] = m.colour, m.shininess
        s["colour_map"], s["normal_map"], s["height_map"] = m.colour_map, m.normal_map, m.height_map
        s["wrap"], s["height_scale"] = types.WRAP_MODES[m.wrap], m.height_scale
        s["uv_scale"], s["uv_offset"] = m.uv_scale, m.uv_offset
    return a


def texture_structs(scene):
    """(Texture table, MipLevel table, texels, sRGB decoding table) of all the scene's textures."""
    texels, levels, textures = mipmap.pack(scene.textures, scene.path)
    return textures, levels, texels, mipmap.SRGB8_TO_LINEAR.astype(np.float32)


def params_struct(scene, spp=1, light_samples=1, width=1, height=1, texture_filter="trilinear",
                  pixel_pattern=None, light_pattern=None, seed=0):
    """RenderParams; the patterns default to one centre sample (raytrace.samplers.Pattern)."""
    p = np.zeros((), types.RENDER_PARAMS)
    p["ambient"] = scene.ambient
    p["n_rectangles"], p["n_triangles"] = len(scene.rectangles), len(scene.triangles)
    p["n_ellipsoids"], p["n_lights"] = len(scene.ellipsoids), len(scene.lights)
    center = samplers.pattern("center", 1)
    p["pixel_sampler"] = (pixel_pattern or center).sampler_struct()
    p["light_sampler"] = (light_pattern or center).sampler_struct()
    p["seed"] = seed % 2**32
    p["light_samples"], p["width"], p["height"] = light_samples, width, height
    p["texture_filter"] = types.FILTERS[texture_filter]
    # Ray differentials span one sample spacing, but at least 1/8 pixel, as pbrt-v4's RayIntegrator does.
    p["footprint_scale"] = max(0.125, 1 / math.sqrt(spp))
    return p


def scene_structs(scene, width, height, spp, light_samples, texture_filter, pixel_pattern=None, light_pattern=None,
                  seed=0):
    """The render kernel's scene buffers, in its argument order, up to the textures."""
    return [camera_struct(scene.camera, width, height),
            params_struct(scene, spp, light_samples, width, height, texture_filter, pixel_pattern, light_pattern,
                          seed),
            rectangle_structs(scene.rectangles), triangle_structs(scene.triangles),
            triangle_uv_structs(scene.triangles), ellipsoid_structs(scene.ellipsoids),
            light_structs(scene.lights), material_structs(scene.materials)]
