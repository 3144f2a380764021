"""The tables a render passes to the kernel, named after kernels/scene.h's parameters: the structs of
packing.py and the geometry of geometry.py, with each live scene's triangles and BVH kept between renders."""
import weakref

import numpy as np

from .. import structs
from ..aovs import stores
from ..scene.course_maps import kernel_materials
from .culling import scene_extent
from .geometry import bvh_structs, in_leaf_order, triangle_soup
from .film_filter import parameters
from .packing import (affine_shape_structs, instance_structs, attribute_table, camera_struct, ellipsoid_structs, emitter_tables, environment_table, light_structs, material_structs, params_struct,
                      rectangle_structs, shape_index_table, triangle_normal_records, triangle_records, triangle_uv_records)


# Each live Scene object's packed triangles and BVH, by id(scene): repeated renders of one Scene object (bench's
# scenes in turns, converge, bench --scaling's two meshes alternating, a progressive render's callers) pack its
# triangles and build its BVH once (bench's turns took less time than when only the last scene's were kept
# and mesh_cornell's BVH was built again every turn: measured in commit 8b112a1). An entry goes with its scene
# (weakref.finalize), so an id is never met again while its entry stands. An entry also holds the fingerprint
# the scene was last checked with (Scene.checked, renewed by render() when the scene changed in place and by
# raytrace.parameters' update()), so a changed scene is packed anew.
_GEOMETRY = {}


def _geometry_tables(scene, uv, smooth, use_bvh):
    """Triangle, TriangleUV, TriangleNormals, BVHNode, primitive-reference, culled-subtree, mesh-attribute
    (in the triangles' order) and Instance tables, and the triangles' shapes (TriangleSoup.shape, in their
    order)."""
    key, cached = (uv, smooth, use_bvh, scene.checked), _GEOMETRY.get(id(scene))
    if cached is not None and cached[0] == key:
        return cached[1]
    soup = triangle_soup(scene)
    nodes, prims, culled, roots = bvh_structs(scene, use_bvh, soup)
    if use_bvh:
        soup, prims = in_leaf_order(soup, prims)
    unused = lambda dtype: np.zeros(1, dtype)  # noqa: E731
    tables = [triangle_records(soup.v, soup.material),
              triangle_uv_records(soup.v, soup.uv) if uv else unused(structs.TRIANGLE_UV),
              triangle_normal_records(soup.normals) if smooth else unused(structs.TRIANGLE_NORMALS),
              nodes, prims, culled, attribute_table(soup.attributes), instance_structs(scene, roots), soup.shape]
    if cached is None:
        weakref.finalize(scene, _GEOMETRY.pop, id(scene), None)
    _GEOMETRY[id(scene)] = key, tables
    return tables


def film(scene, width, height):
    """(film width, film height, crop) of an image of width x height pixels: the scene's film and its crop
    window where it has one (the image is that window), else the whole of a film of the image's size."""
    crop = scene.crop
    if crop == (0, 0, scene.width, scene.height):
        return width, height, None
    return scene.width, scene.height, crop


def scene_tables(scene, width=1, height=1, spp=1, light_samples=1, texture_filter="trilinear", pixel_pattern=None,
                 light_pattern=None, seed=0, features=None):
    """The scene's tables, named after kernels/scene.h's SCENE_PARAMETERS. Tables a variant does not read
    (uvs without textures, normals without smooth meshes, the BVH without HAS_BVH, the shapes' numbers without
    the shape_index AOV) are one dummy entry: features None packs them all but the BVH. The uv AOV reads the
    triangles' uvs (aovs.cl's aov_uv, a mesh without uvs its barycentrics) with or without textures."""
    uv = features is None or features.textures or stores(features.aovs, "uv")
    triangles, uvs, normals, nodes, prims, culled, attributes, instances, shapes = _geometry_tables(
        scene, uv, features is None or features.smooth_normals,
        features is not None and features.bvh)
    params = params_struct(scene, spp, light_samples, width, height, texture_filter, pixel_pattern, light_pattern,
                           seed)
    params["scene_extent"] = scene_extent(scene, triangles)
    emitters, emitter_triangles = emitter_tables(scene, triangles)
    return {"camera": camera_struct(scene.camera, *film(scene, width, height), parameters(scene),
                                     scene.sample_border), "params": params,
            "rectangles": rectangle_structs(scene.rectangles), "triangles": triangles, "triangle_uvs": uvs,
            "triangle_normals": normals, "ellipsoids": ellipsoid_structs(scene.ellipsoids),
            "disks": affine_shape_structs(scene.disks), "cylinders": affine_shape_structs(scene.cylinders),
            "lights": light_structs(scene.lights, scene.rectangles, scene_extent(scene, triangles)),
            "materials": material_structs(kernel_materials(scene)), "nodes": nodes, "prims": prims,
            "culled_subtrees": culled, "attributes": attributes, "emitters": emitters,
            "emitter_triangles": emitter_triangles, "instances": instances,
            "shape_indices": shape_index_table(scene, shapes) if features is None
            or stores(features.aovs, "shape_index") else np.zeros(1, np.int32),
            "environment_map": environment_table(scene) if features is None or features.environment_map
            else np.zeros(1, np.float32)}
