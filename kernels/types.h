/* Every struct the kernel reads from the host. Mirrored once, field for field, by the numpy dtypes in
 * raytrace/structs.py; tests/test_types.py checks sizes and offsets against this device's compiler.
 * Only 4-byte scalars and arrays of them: no float3/float4 members, so no hidden padding anywhere. */
#ifndef TYPES_H
#define TYPES_H

#include "lanes.h"
#include "limits.h"

typedef struct { float x, y, z; } Vec3f;

typedef struct {
    Vec3f position, forward, right, up; /* orthonormal basis of docs/model.md, camera */
    float scale_x;                      /* (W/H) * f * tan(fov/2); orthographic: half the view's width */
    float scale_y;                      /* f * tan(fov/2); orthographic: half the view's height */
    float focal_length;
    float near_clip, far_clip;          /* distances along forward (Mitsuba's); 0 and INFINITY: none */
    float lens_radius, focus_distance;  /* thinlens (HAS_THIN_LENS): the aperture's radius, the focal plane's distance */
    int film_width, film_height;        /* the whole film, in pixels */
    int crop_x, crop_y, crop_width, crop_height; /* the rendered window of the film (hdrfilm's crop) */
    int rfilter;                        /* RFILTER_*: the reconstruction filter (film_filter.cl, HAS_RFILTER) */
    int rfilter_bins;                   /* its table's bins, spacing rfilter_step, over [-rfilter_reach, reach] */
    int rfilter_border;                 /* samples may fall outside the crop window (hdrfilm's sample_border) */
    float rfilter_reach, rfilter_step, rfilter_a, rfilter_b; /* a, b: the filter's parameters (film_filter.cl) */
    float rfilter_integral;             /* the filter's integral over the line */
    float rfilter_pdf[RFILTER_NODES];   /* |f| at the nodes, normalised: the piecewise-linear sampling density */
    float rfilter_cdf[RFILTER_NODES];   /* that density's integral from -reach to each node */
    float rfilter_cumulative[RFILTER_NODES]; /* f's own integral from -reach to each node, over rfilter_integral */
    float depth_from;                   /* the depth AOV's near plane where the rays start at the eye (aovs.cl) */
} Camera;

typedef struct {
    Vec3f center, normal, tangent, bitangent; /* bitangent = normal x tangent */
    float half_x, half_y;                     /* half of the size along tangent and bitangent */
    int material;
} Rectangle;

typedef struct {
    Vec3f v0, v1, v2;
    Vec3f normal; /* normalize((v1 - v0) x (v2 - v1)) */
    int material;
} Triangle;

/* Texture coordinates of a triangle, read only when shading (kept apart from the intersection data). */
typedef struct {
    float uv[6];          /* (u, v) of v0, v1, v2 */
    Vec3f dpdu, dpdv;     /* the uv parameterisation's derivatives, constant over the triangle */
    Vec3f tangent;        /* unit direction of dpdu */
} TriangleUV;

/* Shading normals at a triangle's corners, interpolated over a smooth mesh (the face's own normal, thrice,
 * elsewhere); read only when shading, and only by kernels built with HAS_SMOOTH_NORMALS. */
typedef struct { Vec3f n0, n1, n2; } TriangleNormals;

typedef struct {
    Vec3f center;
    float world_to_unit[9]; /* row-major inverse of [a b c]: world offsets to unit-sphere space */
    float unit_to_world[9]; /* row-major [a b c] (columns are the axes), for dp/du and dp/dv */
    float normal_sign;      /* 1, or -1 where flip_normals turns its front inwards (Mitsuba's sphere's) */
    int material;
} Ellipsoid;

/* Mitsuba 3's disk and cylinder, each a unit shape under an affine map x -> center + to_world x (the map's
 * 3 x 3 part row-major, its float64 inverse rounded once): the disk x^2 + y^2 <= 1 in z = 0, the open
 * cylinder x^2 + y^2 = 1, 0 <= z <= 1 (p0, p1 and radius already composed into the map). Their normal is
 * to_local^T of the local one (0, 0, 1), or (x, y, 0), times normal_sign (-1: flip_normals). */
typedef struct {
    Vec3f center;
    float to_local[9];
    float to_world[9];
    float normal_sign;
    int material;
} AffineShape;
typedef AffineShape Disk;
typedef AffineShape Cylinder;

/* An instance of a shape group (Mitsuba's shapegroup and instance; bvh.cl): the group's triangles, kept once
 * in the Triangle table in the group's own space under a BVH of their own (rooted at node `root`), placed by the
 * affine map x -> center + to_world x (3 x 3 row-major; to_local its float64 inverse rounded once). */
typedef struct {
    Vec3f center;
    float to_local[9];
    float to_world[9];
    int root;
} Instance;

/* Shape kinds; a primitive reference in the BVH's table is index * PRIM_KINDS + kind (PRIM_KIND, PRIM_INDEX). */
#define SHAPE_NONE 0 /* nothing, or a light */
#define SHAPE_RECTANGLE 1
#define SHAPE_TRIANGLE 2
#define SHAPE_ELLIPSOID 3
#define SHAPE_DISK 4
#define SHAPE_CYLINDER 5
#define SHAPE_INSTANCE 6 /* in the top level of a two-level BVH: an Instance, alone in its leaf */
#define PRIM_KIND_BITS 3
#define PRIM_KINDS (1 << PRIM_KIND_BITS)
#define PRIM_KIND(ref) ((ref) & (PRIM_KINDS - 1))
#define PRIM_INDEX(ref) ((ref) >> PRIM_KIND_BITS)
#define SHAPE_REFERENCE(kind, index) ((index) * PRIM_KINDS + (kind))

/* A node of the flattened BVH (bvh.cl), depth first: count > 0 is a leaf of the primitive references
 * [offset, offset + count); count <= 0 an interior node whose first child is the next node, second child node
 * `offset`, split along axis -count. Boxes are rounded outwards to float32. */
typedef struct {
    float lo[3], hi[3];
    int offset, count;
} BVHNode;

/* Bit i of planes_in_front (planes_behind), i < CULLED_RECTANGLES: the whole light, as shadow rays sample it, lies strictly
 * in front of (behind) rectangle i's plane, so that no shadow ray from that side can cross it (intersect.cl). */
typedef struct {
    Rectangle shape; /* shape.material: the path model's reflecting material, -1 none (black) */
    Vec3f colour;
    uint planes_in_front, planes_behind;
} Light;

/* Emitters that are no shape (Mitsuba's point, spot, directional and projector; kernels/emitters.cl): delta
 * lights, which no ray meets and no BSDF sample reaches, so that their light samples count whole (weight 1). */
#define EMITTER_POINT 8
#define EMITTER_SPOT 9
#define EMITTER_DIRECTIONAL 10
#define EMITTER_PROJECTOR 11
#define EMITTER_IS_DELTA(kind) ((kind) >= EMITTER_POINT)

/* An emitter (kernels/emitters.cl). An area emitter on a shape (Mitsuba's `area` on any shape): its shape's points
 * emit the radiance from their front side (the side the shape's normal points to). Each emitting shape has a
 * material of its own, whose `emitter` names it, so that a hit finds its emission through the material it reads
 * anyway. A delta light (EMITTER_*): `radiance` is a point's or spot's intensity, a directional's irradiance, a
 * projector's pi scale times its constant irradiance (1 with an image, `lookup`). */
typedef struct {
    int kind;      /* SHAPE_*: SHAPE_TRIANGLE, a mesh's triangles; or one rectangle or (a sphere) ellipsoid; or EMITTER_* */
    int index;     /* the rectangle's or ellipsoid's index; a mesh's first entry in the EmitterTriangle table */
    int count;     /* a mesh's triangles (1 for the other kinds) */
    int reflects;  /* 0: its material is black (no BSDF: Mitsuba's default for an emitting shape) */
    float area;    /* the whole shape's area: triangles are chosen in proportion to theirs */
    Vec3f position;      /* point, spot, projector: where the light is */
    Vec3f axis;          /* directional: the unit direction its light travels; projector: to_world (0, 0, 1) */
    float to_local[9];   /* spot, projector: the world-to-light 3 x 3 map (row-major), light's +z its axis */
    float cos_cutoff;    /* spot: cos(cutoff_angle), beyond which it is black */
    float cos_beam;      /* spot: cos(beam_width), within which the falloff is 1 */
    float cutoff;        /* spot: cutoff_angle in radians */
    float inv_transition; /* spot: 1 / (cutoff - beam_width) in radians: the linear falloff's slope */
    float uv_scale[2];   /* spot, projector: (u, v) = 1/2 + uv_scale (x, y) / (2 z), Mitsuba's image coordinates */
    int lookup;          /* spot's texture, projector's irradiance image: a TextureLookup, -1 none */
    Vec3f radiance;
    /* Its share in choosing the emitter of a light sample (light_selection.cl): the probability, and the
     * cumulative probability up to and including it (the last emitter's is 1). */
    float selection_pdf, selection_cdf;
} Emitter;

/* A triangle of an emitting mesh and the cumulative share of the mesh's area up to and including it: the
 * triangles are chosen by a binary search on it (the last is 1). */
typedef struct {
    int triangle;
    float cdf;
} EmitterTriangle;

#define WRAP_REPEAT 0
#define WRAP_CLAMP 1
#define WRAP_MIRROR 2

/* A material's parameters that may vary over the surface (Mitsuba's textured parameters): the index in
 * Material.maps of each one's TextureLookup. */
#define MAP_COLOUR 0   /* colour: diffuse's reflectance, the conductors' and glass's specular_reflectance, the
                        * plastics' diffuse_reflectance */
#define MAP_SPECULAR 1 /* the plastics' specular_reflectance */
#define MAP_ALPHA 2    /* the rough BSDFs' alpha (alpha_u) */
#define MAP_ALPHA_V 3  /* their alpha_v */
#define MAP_WEIGHT 4   /* a blend's weight: blendbsdf's weight, mask's opacity */
#define MAP_NORMAL 5   /* Mitsuba's normalmap: a tangent-space normal, rgb = (n + 1) / 2 */
#define MAP_BUMP 6     /* Mitsuba's bumpmap: a height field, whose gradient tilts the normal (times bump_scale) */
/* principled's weights (Mitsuba's names; its base_color is MAP_COLOUR): a float each, read under
 * HAS_PRINCIPLED_LOOKUPS (material.cl's principled_lookups), which derives the alphas and the clearcoat's too */
#define MAP_ROUGHNESS 7
#define MAP_ANISOTROPIC 8
#define MAP_METALLIC 9
#define MAP_SPEC_TINT 10
#define MAP_SHEEN 11
#define MAP_SHEEN_TINT 12
#define MAP_CLEARCOAT 13
#define MAP_CLEARCOAT_GLOSS 14
#define MAP_SPEC_TRANS 15
/* flatness (principled's and principledthin's), then principledthin's own: diff_trans (its lookup halved, as
 * Mitsuba takes it) and its eta, from which the transmission's alphas derive too */
#define MAP_FLATNESS 16
#define MAP_DIFF_TRANS 17
#define MAP_PRINCIPLED_ETA 18
/* the conductors' eta and k, a colour each */
#define MAP_ETA 19
#define MAP_K 20

/* How a textured parameter finds its value at a surface point (Mitsuba's texture plugins; lookups.cl). */
#define LOOKUP_BITMAP 0       /* an image, filtered */
#define LOOKUP_CHECKERBOARD 1 /* colour0 and colour1 in alternate squares of a 2 x 2 tile of (s, t) */
#define LOOKUP_MESH_ATTRIBUTE 2 /* a mesh's per-vertex attribute, interpolated over the triangle hit */

typedef struct {
    int kind;              /* LOOKUP_* */
    int texture;           /* LOOKUP_BITMAP: the image's index in the Texture table */
    int wrap, filter;      /* LOOKUP_BITMAP: WRAP_*; FILTER_*, or -1: the render's texture_filter */
    int luminance;         /* a float parameter: an image's luminance, a checkerboard colour's mean (Mitsuba's
                            * eval_1) */
    float to_uv[6];        /* (s, t) = rows (to_uv[0..2], to_uv[3..5]) . (u, v, 1): the texture's coordinates,
                            * s along the image's rows, t down its columns (the image's top-left is (0, 0)) */
    Vec3f colour0, colour1; /* LOOKUP_CHECKERBOARD */
    int attribute;         /* LOOKUP_MESH_ATTRIBUTE: its first entry in the attribute table (one per triangle) */
    float scale;           /* LOOKUP_MESH_ATTRIBUTE: a factor on its values */
} TextureLookup;

/* A mesh attribute's values at a triangle's corners v0, v1, v2 (LOOKUP_MESH_ATTRIBUTE). */
typedef struct { Vec3f a0, a1, a2; } TriangleAttribute;

typedef struct {
    Vec3f colour;                    /* ka = kd = ks = colour (the course's model), unless a colour map */
    float shininess;
    int colour_map, normal_map, height_map; /* indices into the Texture table, -1 for none */
    int wrap;                        /* WRAP_* */
    float height_scale;              /* scene units per unit of height */
    float uv_scale[2], uv_offset[2]; /* (u, v) -> uv_scale * (u, v) + uv_offset before every lookup */
    int bsdf;                        /* BSDF_*: the path model's; the other models are Lambertian or Phong */
    Vec3f eta, k;                    /* conductors: eta + i k per channel (0, 0: a perfect mirror);
                                      * dielectrics and plastics: eta.x = int_ior / ext_ior */
    float alpha, alpha_v;            /* the rough BSDFs' roughness along u and along v (alpha_v = alpha: isotropic) */
    int distribution;                /* the rough BSDFs' MICROFACET_* */
    Vec3f specular;                  /* plastic, roughplastic: the coat's specular_reflectance */
    int nonlinear;                   /* plastic, roughplastic: Mitsuba's `nonlinear` (the colour shifts with the
                                      * light trapped under the coat) */
    float internal_reflectance;      /* plastic, roughplastic: the share of diffuse light the coat reflects back
                                      * inside (raytrace/scene/plastic_terms.py) */
    float specular_weight;           /* plastic, roughplastic: the coat's share in choosing a lobe to sample */
    float transmittance[ROUGH_TRANSMITTANCE_RES]; /* roughplastic: the coat's transmittance at cos(theta) = i / (RES
                                      * - 1), i = 0 .. RES - 1 (raytrace/scene/rough_transmittance.py) */
    int maps[MAPS];                  /* each textured parameter's TextureLookup (MAP_*), -1: its value above */
    int back;                        /* the material of the back side (where the normal points away from the
                                      * viewer): its own index (two-sided), another's (Mitsuba's twosided of two
                                      * BSDFs), or -1: black (Mitsuba's one-sided BSDFs) */
    int blend[2];                    /* BSDF_BLEND: the materials it mixes (wrappers.cl) */
    float weight;                    /* BSDF_BLEND: the second one's share, unless maps[MAP_WEIGHT] */
    float bump_scale;                /* maps[MAP_BUMP]: scene units of relief per unit of the height field */
    int mirrored_maps;               /* normalmap, bumpmap: the back side sees the map's normal mirrored through
                                      * the surface (Mitsuba's twosided around the map), not turned whole */
    float principled[PRINCIPLED_PARAMETERS]; /* principled: its values, PRINCIPLED_* below (its eta in eta.x, its
                                      * main lobe's GGX roughness in alpha, alpha_v: principled_terms.py) */
    int emitter;                     /* the Emitter of the one shape with this material, -1 for none */
} Material;

/* The principled BSDF's values in Material.principled (and ShadingPoint.principled): Mitsuba's parameters, but
 * the clearcoat's GTR1 roughness in place of its clearcoat_gloss. */
#define PRINCIPLED_ROUGHNESS 0
#define PRINCIPLED_METALLIC 1
#define PRINCIPLED_SPEC_TINT 2
#define PRINCIPLED_SHEEN 3
#define PRINCIPLED_SHEEN_TINT 4
#define PRINCIPLED_CLEARCOAT 5
#define PRINCIPLED_CLEARCOAT_ALPHA 6
#define PRINCIPLED_SPEC_TRANS 7
#define PRINCIPLED_SPECULAR_RATE 8  /* main_specular_sampling_rate */
#define PRINCIPLED_CLEARCOAT_RATE 9 /* clearcoat_sampling_rate */
#define PRINCIPLED_DIFFUSE_RATE 10  /* diffuse_reflectance_sampling_rate */
#define PRINCIPLED_ANISOTROPIC 11   /* anisotropic, which the alphas derive from where roughness or it is textured */
#define PRINCIPLED_TRANSMITS 12     /* 1: Mitsuba's has_spec_trans (spec_trans given and not 0, or textured): the
                                     * inside and the transmission exist, even where the weights make them 0 */
/* principledthin's own (raytrace/scene/principled_terms.py; it shares ROUGHNESS, SPEC_TINT, SHEEN, SHEEN_TINT,
 * SPEC_TRANS, SPECULAR_RATE as its specular_reflectance_sampling_rate and DIFFUSE_RATE; its eta in eta.x, its
 * reflection's GGX roughness in alpha, alpha_v) */
#define PRINCIPLED_FLATNESS 13        /* flatness (principled's too: its fake subsurface lobe) */
#define PRINCIPLED_DIFF_TRANS 14       /* diff_trans / 2: the diffuse light's share transmitted, in [0, 1] */
#define PRINCIPLED_TRANS_ALPHA_U 15    /* the transmission's GGX roughness, of (0.65 eta - 0.35) roughness */
#define PRINCIPLED_TRANS_ALPHA_V 16
#define PRINCIPLED_SPEC_TRANS_RATE 17  /* specular_transmittance_sampling_rate */
#define PRINCIPLED_DIFF_TRANS_RATE 18  /* diffuse_transmittance_sampling_rate */

/* The path model's BSDFs, one file each in kernels/bsdfs/ (bsdf.cl), numbered as raytrace/scene/model.py's BSDFS. */
#define BSDF_DIFFUSE 0
#define BSDF_CONDUCTOR 1
#define BSDF_DIELECTRIC 2
#define BSDF_ROUGHCONDUCTOR 3
#define BSDF_THINDIELECTRIC 4
#define BSDF_ROUGHDIELECTRIC 5
#define BSDF_PLASTIC 6
#define BSDF_ROUGHPLASTIC 7
#define BSDF_NULL 8
#define BSDF_PRINCIPLED 9
#define BSDF_PRINCIPLEDTHIN 10
/* Not a BSDF: a node that mixes two materials (Mitsuba's blendbsdf, and mask: a null and the masked one),
 * resolved at each hit into one of them (wrappers.cl). */
#define BSDF_BLEND 31

/* The rough BSDFs' microfacet distributions (microfacet.cl), with Mitsuba's names. */
#define MICROFACET_GGX 0
#define MICROFACET_BECKMANN 1

/* How a texture's texels are stored in the packed buffer of 32-bit words. */
#define TEXELS_SRGB8 0  /* RGBA8 in one word, r in the low byte, sRGB-encoded: decoded through a table */
#define TEXELS_UNORM8 1 /* RGBA8 in one word, linear data (normal and height maps) */
#define TEXELS_FLOAT 2  /* RGBA float32 in four words */
/* Height maps, whose height is the first channel, store each texel's quad instead: its own height, then those
 * of (i + 1, j), (i, j + 1) and (i + 1, j + 1), 0 beyond the level's edges, so that a bilinear lookup within
 * the edges reads one texel instead of four (textures.cl). */
#define TEXELS_QUAD8 3  /* four 8-bit heights in one word, the texel's own in the low byte */
#define TEXELS_QUADF 4  /* four float32 heights in four words */
#define TEXELS_QUAD16 5 /* four 16-bit heights (code / 65535) in two words: the texel's own and its right
                           neighbour's in the first (own in the low half), the lower two in the second */
#define TEXELS_ARE_QUADS(e) ((e) == TEXELS_QUAD8 || (e) == TEXELS_QUADF || (e) == TEXELS_QUAD16)

typedef struct {
    int first_level, n_levels; /* its levels in the MipLevel table, finest first */
    int encoding;              /* TEXELS_* */
} Texture;

typedef struct {
    int offset;        /* first word of the level in the texel buffer; rows top to bottom */
    int width, height;
} MipLevel;

#define FILTER_NEAREST 0
#define FILTER_BILINEAR 1
#define FILTER_TRILINEAR 2
#define FILTER_ANISOTROPIC 3

/* The film's reconstruction filters (types.h's Camera.rfilter; film_filter.cl), Mitsuba's rfilter plugins. */
#define RFILTER_BOX 0
#define RFILTER_TENT 1
#define RFILTER_GAUSSIAN 2
#define RFILTER_MITCHELL 3
#define RFILTER_LANCZOS 4

/* The AOV types (kernels/aovs.cl; Mitsuba's aov integrator's, raytrace/aovs.py's TYPES in this order): bits of
 * HAS_AOVS, and their output planes, in this order after render.cl's OUTPUT_PLANES. */
#define AOV_ALBEDO 1      /* R, G, B */
#define AOV_SH_NORMAL 2   /* X, Y, Z */
#define AOV_GEO_NORMAL 4  /* X, Y, Z */
#define AOV_DEPTH 8       /* T */
#define AOV_POSITION 16   /* X, Y, Z */
#define AOV_UV 32         /* U, V */
#define AOV_SHAPE_INDEX 64 /* I */
#define AOV_PLANES (((HAS_AOVS & AOV_ALBEDO) ? 3 : 0) + ((HAS_AOVS & AOV_SH_NORMAL) ? 3 : 0)                     \
                    + ((HAS_AOVS & AOV_GEO_NORMAL) ? 3 : 0) + ((HAS_AOVS & AOV_DEPTH) ? 1 : 0)                  \
                    + ((HAS_AOVS & AOV_POSITION) ? 3 : 0) + ((HAS_AOVS & AOV_UV) ? 2 : 0)                       \
                    + ((HAS_AOVS & AOV_SHAPE_INDEX) ? 1 : 0))

/* How a sample pattern's table (points in 0.32 fixed point, the same for every pixel) is randomised per
 * pixel and per sample stream, so that neighbouring pixels get independent patterns (samplers.cl). */
#define RANDOMIZE_NONE 0        /* the table as it is: center, grid, rotated grids */
#define RANDOMIZE_INDEPENDENT 1 /* the table is ignored: a fresh uniform point per sample (random) */
#define RANDOMIZE_JITTER 2      /* table = stratum corners, plus a uniform offset within the stratum */
#define RANDOMIZE_SHIFT 3       /* a Cranley-Patterson rotation per stream (halton) */
#define RANDOMIZE_SOBOL 4       /* the table is ignored: Owen-scrambled Sobol points per dimension pair */

typedef struct {
    int randomize;      /* RANDOMIZE_* */
    uint cell_x, cell_y; /* RANDOMIZE_JITTER: the stratum's size in units of 2^-24 */
} Sampler;

typedef struct {
    Vec3f ambient;
    int n_rectangles, n_triangles, n_ellipsoids, n_lights;
    int n_emitters;        /* HAS_EMITTERS: the Emitter table's entries */
    Sampler pixel_sampler, light_sampler;
    uint seed;
    int light_samples;
    int width, height;
    int texture_filter;    /* FILTER_* */
    float footprint_scale; /* spacing of the pixel samples in pixels (1 / sqrt(spp)): ray differentials */
    int max_depth;         /* the path model's vertices per path (-1: unbounded; path_tracing.cl) */
    Vec3f environment;     /* the path model's environment radiance: constant, or an envmap's scale */
    float scene_extent;    /* a bound on every coordinate of the scene (renderer/culling.py) */
    int environment_width, environment_height; /* HAS_ENVIRONMENT_MAP: the map's texels (environment.cl) */
    Vec3f environment_x, environment_y, environment_z; /* the world directions of the map's local axes */
    int n_disks, n_cylinders;
    int n_instances;       /* HAS_INSTANCES: the Instance table's entries */
    int rr_depth;          /* the path model's first vertex at which Russian roulette may end a path (roulette.cl) */
    int hide_emitters;     /* the radiometric models: camera rays do not see the emitters (hide_emitters.cl) */
    int bsdf_samples;      /* HAS_BSDF_SAMPLING: the direct model's BSDF samples (direct_lighting.cl) */
} RenderParams;


inline vec3 v3_uniform(Vec3f a) { return v3_splat(a.x, a.y, a.z); }
inline float3 f3(Vec3f a) { return (float3)(a.x, a.y, a.z); }

#endif
