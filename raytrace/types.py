"""numpy mirrors of the structs in kernels/types.h, field for field (tests/test_types.py checks them
against the device's own sizeof/offsetof)."""
import numpy as np

VEC3F = ("<f4", (3,))

CAMERA = np.dtype([("position", *VEC3F), ("forward", *VEC3F), ("right", *VEC3F), ("up", *VEC3F),
                   ("scale_x", "<f4"), ("scale_y", "<f4"), ("focal_length", "<f4")])

RECTANGLE = np.dtype([("center", *VEC3F), ("normal", *VEC3F), ("tangent", *VEC3F), ("bitangent", *VEC3F),
                      ("half_x", "<f4"), ("half_y", "<f4"), ("material", "<i4")])

TRIANGLE = np.dtype([("v0", *VEC3F), ("v1", *VEC3F), ("v2", *VEC3F), ("normal", *VEC3F), ("material", "<i4")])

ELLIPSOID = np.dtype([("center", *VEC3F), ("world_to_unit", "<f4", (9,)), ("material", "<i4")])

LIGHT = np.dtype([("shape", RECTANGLE), ("colour", *VEC3F)])

MATERIAL = np.dtype([("colour", *VEC3F), ("shininess", "<f4")])

RENDER_PARAMS = np.dtype([("ambient", *VEC3F), ("n_rectangles", "<i4"), ("n_triangles", "<i4"),
                          ("n_ellipsoids", "<i4"), ("n_lights", "<i4"), ("spp", "<i4"),
                          ("light_samples", "<i4"), ("width", "<i4"), ("height", "<i4")])

# name in kernels/types.h -> dtype
STRUCTS = {"Camera": CAMERA, "Rectangle": RECTANGLE, "Triangle": TRIANGLE, "Ellipsoid": ELLIPSOID,
           "Light": LIGHT, "Material": MATERIAL, "RenderParams": RENDER_PARAMS}
