"""The course's normal and height maps in the path model: Mitsuba 3's `normalmap` and `bumpmap`.

A material's `normal_map` (tangent-space normals, rgb = (n + 1) / 2) and `height_map` (relief times
`height_scale`) are the course's (docs/textures.md): the Phong and direct models shade with them as the course
specifies (kernels/material.cl's texture_material: the normal in the uv frame of the shape, the height map's
gradient by finite differences over the pixel's footprint, and the shading point displaced by the relief). In
the path model they become the wrappers every BSDF there takes (material.cl's perturb_normal, bsdf.cl's
perturbed_factor): the normal map a `normalmap`, the height map a `bumpmap` of scale height_scale, both reading
the same image through the material's uv transform and wrap mode with the render's filter; both maps together,
Mitsuba's bumpmap around a normalmap (the normal map in the bumped frame, where the course tilts the
normal-mapped normal by the height's gradient). So the path model has one way to tilt a shading normal,
Mitsuba's: its frame (dp/du made orthogonal to the shading normal), its invalid-normal mirror, its side rule, the
shadowing term at the tilted normal's terminator, and a bump's gradient from the finest level's bilinear cell.
What the path model leaves out of the course's: the displacement (a bump map moves no point, as in Mitsuba and
pbrt-v4).

The scene keeps the course's fields; the kernel's materials are derived here, for the model the render renders
(render() may change the shading model of a scene), by Features.of and the packing alike."""
import dataclasses

from .model import TextureLookup


def _as_wrappers(material):
    """The material with its course maps as Mitsuba's normalmap or bumpmap (maps "normal", "bump")."""
    su, sv = material.uv_scale
    ou, ov = material.uv_offset
    to_uv = (su, 0.0, ou, 0.0, sv, ov)  # (s, t) = uv_scale (u, v) + uv_offset, t up the image as v
    maps = list(material.maps)
    if material.normal_map >= 0:
        maps.append(("normal", TextureLookup("bitmap", material.normal_map, material.wrap, None, to_uv)))
    if material.height_map >= 0:
        maps.append(("bump", TextureLookup("bitmap", material.height_map, material.wrap, None, to_uv)))
    return dataclasses.replace(material, normal_map=-1, height_map=-1, height_scale=0.0, maps=tuple(maps),
                               bump_scale=material.height_scale if material.height_map >= 0 else
                               material.bump_scale)


def kernel_materials(scene):
    """The materials as the kernel takes them: in the path model, the course's maps as Mitsuba's wrappers."""
    if scene.shading != "path":
        return scene.materials
    return [_as_wrappers(m) if m.normal_map >= 0 or m.height_map >= 0 else m for m in scene.materials]
