/* The scene as the kernel sees it: the host's buffers and counts, gathered in one private struct.
 * HAS_RECTANGLES, HAS_TRIANGLES, HAS_ELLIPSOIDS, HAS_DISKS and HAS_CYLINDERS, and HAS_COLOUR_MAPS, HAS_NORMAL_MAPS and
 * HAS_HEIGHT_MAPS and HAS_SMOOTH_NORMALS (set by the host from the scene) leave out the code of what a scene
 * lacks; HAS_BVH picks traversal of a hierarchy over a loop over every shape, HAS_DIRECT_LIGHTING and
 * HAS_PATH_TRACING the shading model (direct_lighting.cl, path_tracing.cl, else the course's Phong, shading.cl),
 * HAS_BSDF_SAMPLING the direct model's BSDF samples. The kernel's arguments stay the same in every variant.
 * COUNT_VISITS (never derived from a scene: `bench` and `bench --scaling` set it) builds a render
 * kernel that also counts the nodes and primitives its traversals test (below). */
#ifndef SCENE_H
#define SCENE_H

#include "types.h"

/* Any texture at all: hits then carry what is needed to find their texture coordinates. */
#define HAS_TEXTURES (HAS_COLOUR_MAPS || HAS_NORMAL_MAPS || HAS_HEIGHT_MAPS || HAS_LOOKUPS)
/* Hits carry their shape and barycentrics for texturing or for interpolating smooth normals. */
#define HAS_SURFACE_DATA (HAS_TEXTURES || HAS_SMOOTH_NORMALS || HAS_PATH_TRACING || HAS_BSDF_SAMPLING || HAS_AOVS)
                                    /* path and the direct model's BSDF samples: which light; AOVs: uv, shape */
#define RADIOMETRIC (HAS_DIRECT_LIGHTING || HAS_PATH_TRACING) /* lights emit a radiance from their front */
/* The Emitter table's entries: area emitters on shapes, delta lights (point, spot, directional, projector) */
#define HAS_EMITTERS (HAS_SHAPE_EMITTERS || HAS_DELTA_EMITTERS)
/* the path model's BSDFs (bsdf.cl): with a microfacet distribution (microfacet.cl), with a coat over a diffuse
 * base, with hits that must know whether they come from inside (the index of refraction inverts; a back side) */
/* principled.cl's values (ShadingPoint.principled) and helpers, which principledthin.cl shares */
#define HAS_PRINCIPLED_VALUES (HAS_PRINCIPLED || HAS_PRINCIPLEDTHIN)
#define HAS_MICROFACETS (HAS_ROUGH_CONDUCTORS || HAS_ROUGH_DIELECTRICS || HAS_ROUGH_PLASTICS || HAS_PRINCIPLED_VALUES)
#define HAS_COATS (HAS_PLASTICS || HAS_ROUGH_PLASTICS)
#define HAS_BACKFACES (HAS_DIELECTRICS || HAS_ROUGH_DIELECTRICS || HAS_WRAPPERS || HAS_PRINCIPLED_VALUES \
                       || HAS_SHAPE_EMITTERS || HAS_AOVS) /* an emitting shape's back side is black; the AOVs'
                                                           * normals are the shape's own side's (aovs.cl) */
/* shading points carry a BSDF's own values: any BSDF besides diffuse */
#define HAS_BSDF_PARAMETERS (HAS_CONDUCTORS || HAS_DIELECTRICS || HAS_THIN_DIELECTRICS || HAS_MICROFACETS || HAS_COATS \
                             || HAS_NULLS || HAS_PRINCIPLED_VALUES)

/* Every texture's levels, packed into one buffer of 32-bit words (textures.cl). */
typedef struct {
    __global const Texture *textures;
    __global const MipLevel *levels;
    __global const uint *texels;
    __global const float *srgb_to_linear; /* 256 entries: 8-bit sRGB code to linear */
    __global const TextureLookup *lookups; /* the textured parameters' lookups (lookups.cl) */
} TextureStore;

typedef struct {
    __global const Rectangle *rectangles;
    __global const Triangle *triangles;
    __global const TriangleUV *triangle_uvs;
    __global const TriangleNormals *triangle_normals;
    __global const TriangleAttribute *attributes; /* mesh attributes, per triangle (LOOKUP_MESH_ATTRIBUTE) */
    __global const Ellipsoid *ellipsoids;
    __global const Disk *disks;
    __global const Cylinder *cylinders;
    __global const Instance *instances; /* HAS_INSTANCES: the shape groups' placements (bvh.cl) */
    __global const int *shape_indices;  /* the shape_index AOV's: each primitive's shape (aovs.cl's layout) */
    __global const Light *lights;
    __global const Emitter *emitters;                  /* HAS_EMITTERS: area emitters on shapes, delta lights */
    __global const EmitterTriangle *emitter_triangles; /* their meshes' triangles (emitters.cl) */
    __global const Material *materials;
    __constant const Camera *camera;
    __constant const RenderParams *params;
    __global const BVHNode *nodes; /* HAS_BVH: the hierarchy over every shape (bvh.cl) */
    __global const int *prims;     /* its leaves' primitive references, index * PRIM_KINDS + SHAPE_* */
    __global const uint *culled_subtrees; /* per node: the bits of the rectangles it holds when it holds only
                                           * rectangles shadow rays may skip (intersect.cl), else 0 */
    __global const float *environment_map; /* HAS_ENVIRONMENT_MAP: texels and sampling tables (environment.cl) */
#if HAS_NULLS || HAS_DELTA_EMITTERS
    TextureStore textures; /* for shadow rays, the masks' opacities (primitive.cl), and the delta lights' images
                            * (emitters.cl); the kernel sets it */
#endif
#if COUNT_VISITS
    int *visits; /* a measuring build's counts of the work-item's traversal work, VISITS_* below */
#endif
} Scene;

/* A measuring build (COUNT_VISITS) counts what a work-item's traversals test: BVH nodes (their boxes, bvh.cl)
 * and primitives (primitive.cl), of closest-hit and of shadow traversals, once per test of all its lanes. It
 * also counts the path model's vertices (path_tracing.cl's path_vertex): the lanes with a vertex to shade at
 * each step, and LANES per step; their ratio is how busy the lanes are, the share of the work that lanes
 * without a path (theirs ended at this step's hit, or the work-item's samples ran out) do not waste. render.cl stores the counts as planes of its output,
 * raytrace/commands/visits.py reads them. */
#define VISITS_CLOSEST_NODES 0
#define VISITS_SHADOW_NODES 1
#define VISITS_CLOSEST_PRIMITIVES 2
#define VISITS_SHADOW_PRIMITIVES 3
#define VISITS_PATH_LANES 4
#define VISITS_PATH_LANE_STEPS 5
#define VISIT_KINDS 6
#if COUNT_VISITS
#define COUNT_VISIT(s, kind) (++(s)->visits[kind])
#define COUNT_VISITS_ADD(s, kind, n) ((s)->visits[kind] += (n))
#else
#define COUNT_VISIT(s, kind) ((void)0)
#define COUNT_VISITS_ADD(s, kind, n) ((void)0)
#endif

/* The scene and its textures as kernel parameters, declared once: the render kernel (render.cl) and the test
 * kernels that take a whole scene list SCENE_PARAMETERS and TEXTURE_PARAMETERS among their parameters and
 * gather them with SCENE_FROM_PARAMETERS and TEXTURES_FROM_PARAMETERS. The host binds its tables to these
 * names (raytrace/renderer/packing.py packs them under the same names, interface.py checks the types). */
#define SCENE_PARAMETERS                                                                                    \
    __constant const Camera *camera, __constant const RenderParams *params,                               \
    __global const Rectangle *rectangles, __global const Triangle *triangles,                              \
    __global const TriangleUV *triangle_uvs, __global const TriangleNormals *triangle_normals,             \
    __global const TriangleAttribute *attributes,                                                          \
    __global const Ellipsoid *ellipsoids, __global const Light *lights, __global const Material *materials, \
    __global const Emitter *emitters, __global const EmitterTriangle *emitter_triangles,                    \
    __global const BVHNode *nodes, __global const int *prims, __global const uint *culled_subtrees,        \
    __global const float *environment_map, __global const Disk *disks, __global const Cylinder *cylinders,  \
    __global const Instance *instances, __global const int *shape_indices
#define SCENE_FROM_PARAMETERS                                                                               \
    {.rectangles = rectangles, .triangles = triangles, .triangle_uvs = triangle_uvs,                        \
     .triangle_normals = triangle_normals, .attributes = attributes, .ellipsoids = ellipsoids, .lights = lights, .materials = materials, \
     .emitters = emitters, .emitter_triangles = emitter_triangles,                                          \
     .camera = camera, .params = params, .nodes = nodes, .prims = prims, .culled_subtrees = culled_subtrees, \
     .environment_map = environment_map, .disks = disks, .cylinders = cylinders, .instances = instances, \
     .shape_indices = shape_indices}

#define TEXTURE_PARAMETERS                                                                                  \
    __global const Texture *textures, __global const MipLevel *mip_levels, __global const uint *texels,    \
    __global const float *srgb_to_linear, __global const TextureLookup *lookups
#define TEXTURES_FROM_PARAMETERS                                                                            \
    {.textures = textures, .levels = mip_levels, .texels = texels, .srgb_to_linear = srgb_to_linear,       \
     .lookups = lookups}

#endif
