/* The material at a hit: its colour (the material's, or its colour map's), shininess, and where and with
 * which normal it is shaded (normal map, bump map and displacement: docs/textures.md).
 *
 * Without textures (HAS_TEXTURES 0) this is a gather of the material table. With them, each lane's hit
 * geometry (surface.cl) is found one lane at a time, then the lookups and what follows from them run
 * lane-parallel, once per textured material among the lanes (neighbouring pixels mostly share one). */
#ifndef MATERIAL_CL
#define MATERIAL_CL

#include "intersect.cl"
#if HAS_TEXTURES
#include "camera.cl"
#include "mipmap.cl"
#include "surface.cl"
#endif
#if HAS_LOOKUPS
#include "lookups.cl"
#endif
#if HAS_ANISOTROPIC
#include "surface.cl" /* the shapes' dp/du */
#endif

typedef struct {
    vec3 p;            /* the shading point: the hit, displaced by a height map */
    vfloat err;        /* a bound on p's distance from the surface, or from where the height map puts it */
    vec3 ng;           /* geometric unit normal, facing the incoming ray */
    vec3 n;            /* shading unit normal, on the side of ng */
    vec3 k;            /* the material's colour at the hit (0 where no surface was hit) */
    vfloat shininess;
#if HAS_BSDF_PARAMETERS /* the path model's BSDF (bsdf.cl) and its values (types.h's Material) */
    vint bsdf;         /* BSDF_* */
    vec3 eta, k_imag;  /* eta and k */
    vfloat alpha;      /* the roughness (along u) */
#endif
#if HAS_MICROFACETS
    vfloat alpha_v;    /* the roughness along v */
    vint distribution; /* MICROFACET_* */
#endif
#if HAS_ANISOTROPIC
    vec3 t;            /* the shading tangent, the direction of u, orthogonal to n */
#endif
#if HAS_COATS
    vec3 specular;     /* the coat's specular reflectance */
    vint nonlinear;
    vfloat internal_reflectance, specular_weight;
#endif
#if HAS_ROUGH_PLASTICS
    vint material;     /* the material's index, for its table of the coat's transmittance */
    __global const Material *materials;
#endif
#if HAS_BACKFACES
    vint backface;     /* the hit is on the side the normal points away from (inside a closed shape) */
#endif
#if HAS_PERTURBED_NORMALS /* Mitsuba's normalmap and bumpmap (bsdf.cl's perturbed_factor) */
    vec3 n0;           /* the shading normal before the map, on the side of ng */
    vint perturbed;    /* n is the map's */
#endif
#if HAS_PRINCIPLED_VALUES
    vfloat principled[PRINCIPLED_PARAMETERS]; /* the principled BSDF's values (types.h's PRINCIPLED_*) */
#endif
#if HAS_NULLS
    vint passes;       /* the see-through surfaces its shadow rays may pass (primitive.cl): 0 unless the path
                        * model's max_depth leaves more */
#endif
} ShadingPoint;

#if HAS_TEXTURES || (HAS_AOVS & AOV_UV)
#if !HAS_TEXTURES
#include "surface.cl" /* the uv AOV's (aovs.cl) */
#endif

inline SurfacePoint surface_point(const Scene *s, int kind, int index, float3 p, float b1, float b2)
{
#if HAS_TRIANGLES
    if (kind == SHAPE_TRIANGLE)
        return surface_triangle(&s->triangles[index], &s->triangle_uvs[index], b1, b2);
#endif
#if HAS_ELLIPSOIDS
    if (kind == SHAPE_ELLIPSOID)
        return surface_ellipsoid(&s->ellipsoids[index], p);
#endif
#if HAS_DISKS
    if (kind == SHAPE_DISK)
        return surface_disk(&s->disks[index], p);
#endif
#if HAS_CYLINDERS
    if (kind == SHAPE_CYLINDER)
        return surface_cylinder(&s->cylinders[index], p);
#endif
    return surface_rectangle(&s->rectangles[index], p);
}
#endif

#if HAS_TEXTURES

#if HAS_INSTANCES
/* A group's surface point as its instance places it in the world: its vectors by to_world, its normal by the
 * inverse transpose (instances.cl). */
inline SurfacePoint instance_surface(__global const Instance *in, SurfacePoint sp)
{
    sp.dpdu = mat3_mul(in->to_world, sp.dpdu);
    sp.dpdv = mat3_mul(in->to_world, sp.dpdv);
    sp.tangent = normalize3(mat3_mul(in->to_world, sp.tangent));
    sp.n = normalize3(mat3_mul_transposed(in->to_local, sp.n));
    return sp;
}
#endif

/* The surface points of the textured lanes' hits (the other lanes' values are never kept): on lanes where
 * every lane hit one rectangle (neighbouring pixels mostly do: walls and floors), else one lane at a time. */
inline Surface textured_surface(const Scene *s, Hit hit, const int *textured)
{
    int first = FIRST_LANE(hit.index);
    if (ALL((hit.kind == SHAPE_RECTANGLE) & (hit.index == first)))
        return surface_rectangle_lanes(&s->rectangles[first], hit.p);
    int kind[LANES], index[LANES];
    float b1[LANES], b2[LANES];
    VSTORE(hit.kind, kind);
    VSTORE(hit.index, index);
    VSTORE(hit.b1, b1);
    VSTORE(hit.b2, b2);
    Lanes3 p = v3_spill(hit.p);
    SurfaceLanes surface;
    const SurfacePoint none = {(float2)(0.0f), (float3)(0.0f), (float3)(0.0f), (float3)(0.0f), (float3)(0.0f)};
#if HAS_INSTANCES
    int instance[LANES];
    VSTORE(hit.instance, instance);
#endif
    for (int i = 0; i < LANES; ++i) {
        SurfacePoint point = textured[i] ? surface_point(s, kind[i], index[i], lane3(&p, i), b1[i], b2[i]) : none;
#if HAS_INSTANCES
        if (textured[i] && instance[i] >= 0)
            point = instance_surface(&s->instances[instance[i]], point);
#endif
        set_surface_lane(&surface, i, point);
    }
    return surface_fill(&surface);
}

/* What texturing needs of the lanes' hits, before a material's uv transform: the surface points, their
 * shading frames and the footprints of the pixel samples in (u, v). */
typedef struct {
    Surface surface;
    Frame frame;
    UVDerivatives duv;
    vint kind, index;  /* the shapes hit, and a triangle's barycentrics (mesh attributes) */
    vfloat b1, b2;
} TexturedHits;

inline TexturedHits textured_hits(const Scene *s, Hit hit, Surface surface, vec3 d, vec3 p, vec3 ng)
{
    __constant const RenderParams *params = s->params;
    TexturedHits h;
    h.kind = hit.kind;
    h.index = hit.index;
    h.b1 = hit.b1;
    h.b2 = hit.b2;
    h.surface = surface;
    h.frame = shading_frame(h.surface);
    vec3 dpdx, dpdy;
    camera_footprint(s->camera, params->footprint_scale, 1.0f / s->camera->film_width,
                     1.0f / s->camera->film_height, d, p, ng, &dpdx, &dpdy);
    h.duv = uv_derivatives(h.surface, dpdx, dpdy);
    return h;
}

inline int is_textured(__global const Material *m)
{
    int textured = m->colour_map >= 0 || m->normal_map >= 0 || m->height_map >= 0;
#if HAS_LOOKUPS
    for (int slot = 0; slot < MAPS; ++slot)
        textured |= slot != MAP_WEIGHT && m->maps[slot] >= 0; /* (a blend's, resolved before) */
#endif
    return textured;
}

/* The height map's bump: the shading normal of the surface displaced by h along n, from the partial
 * derivatives dh_du, dh_dv (scene units per unit of u and v), without forming the displaced dp/du x dp/dv
 * (pbrt-v4 section 10.5.1), which loses the u direction where dp/du vanishes (an ellipsoid's pole):
 * (dpdu + dh_du n) x (dpdv + dh_dv n) is a multiple of n - grad h, grad h = dh_du e_u + dh_dv e_v with the
 * dual basis e_u = (dpdv x n) / a, e_v = (n x dpdu) / a, a = n.(dpdu x dpdv). Where a is 0, n is kept. */
inline vec3 bump_normal(vec3 dpdu, vec3 dpdv, vec3 n, vfloat dh_du, vfloat dh_dv)
{
    vfloat a = v3_dot(n, v3_cross(dpdu, dpdv));
    vec3 grad = v3_add(v3_scale(v3_cross(dpdv, n), dh_du), v3_scale(v3_cross(n, dpdu), dh_dv));
    return v3_unit_or(v3_sub(n, v3_scale(grad, 1.0f / a)), n);
}

/* *tf becomes the filter of the footprint dst on `texture`: moved from texture *shaped, which it is the filter
 * of, where the two have the same shape (mipmap.cl), else found anew. */
inline void material_filter(TextureStore ts, int texture, Footprint dst, int filter, TextureFilter *tf, int *shaped)
{
    if (*shaped >= 0 && same_shape(ts, *shaped, texture))
        texture_filter_move(ts, texture, tf);
    else
        *tf = texture_filter(ts, texture, dst, filter);
    *shaped = texture;
}

/* Material m's textures on the lanes of `mask` (their hits in h): the colour *k, the shading normal *n (a
 * normal or height map; it starts as the facing geometric normal ng), and the shading point *p displaced by
 * a height map, with its error bound *err (ray.h). Every lane computes; only the mask's lanes keep the
 * results. */
inline void texture_material(TextureStore ts, __global const Material *m, int filter, const TexturedHits *h,
                             vint mask, vec3 ng, vec3 *k, vec3 *n, vec3 *p, vfloat *err)
{
    /* the material's uv transform, then (s, t) = (u, 1 - v) of the image */
    const float scale_u = m->uv_scale[0], scale_v = m->uv_scale[1];
    vec2 st = {MAD(h->surface.uv.x, scale_u, m->uv_offset[0]), 1.0f - MAD(h->surface.uv.y, scale_v, m->uv_offset[1])};
    Footprint dst = {h->duv.u_x * scale_u, -(h->duv.v_x * scale_v), h->duv.u_y * scale_u, -(h->duv.v_y * scale_v)};
    const int wrap = m->wrap;
    vec3 frame_n = h->frame.n, shading = frame_n;
    TextureFilter tf; /* found once for the maps of one shape */
    int shaped = -1;
#if HAS_COLOUR_MAPS
    if (m->colour_map >= 0) {
        material_filter(ts, m->colour_map, dst, filter, &tf, &shaped);
        *k = v3_select(*k, texture_filtered(ts, &tf, st, wrap), mask);
    }
#endif
#if HAS_NORMAL_MAPS
    if (m->normal_map >= 0) { /* tangent space: rgb = (x, y, z) / 2 + 1/2 */
        material_filter(ts, m->normal_map, dst, filter, &tf, &shaped);
        vec3 c = texture_filtered(ts, &tf, st, wrap);
        vec3 mapped = v3_scale(h->frame.t, MAD(c.x, 2.0f, -1.0f));
        mapped = v3_madd(mapped, MAD(c.y, 2.0f, -1.0f), h->frame.b);
        mapped = v3_madd(mapped, MAD(c.z, 2.0f, -1.0f), frame_n);
        shading = v3_unit_or(mapped, frame_n);
    }
#endif
#if HAS_HEIGHT_MAPS
    if (m->height_map >= 0) { /* finite differences over about half the footprint, at least half a texel */
        MipLevel top = ts.levels[ts.textures[m->height_map].first_level];
        vfloat du = vmax(0.5f * (vabs(dst.s_x) + vabs(dst.s_y)), (vfloat)(0.5f / top.width));
        vfloat dv = vmax(0.5f * (vabs(dst.t_x) + vabs(dst.t_y)), (vfloat)(0.5f / top.height));
        vec2 st_u = {st.x + du, st.y}, st_v = {st.x, st.y - dv};
        material_filter(ts, m->height_map, dst, filter, &tf, &shaped);
        vfloat height = texture_filtered(ts, &tf, st, wrap).x;
        vfloat hu = texture_filtered(ts, &tf, st_u, wrap).x;
        vfloat hv = texture_filtered(ts, &tf, st_v, wrap).x;
        vfloat kh = m->height_scale;
        shading = bump_normal(v3_scale(h->surface.dpdu, 1.0f / scale_u), v3_scale(h->surface.dpdv, 1.0f / scale_v),
                              shading, kh * (hu - height) / du, kh * (hv - height) / dv);
        /* outwards (kh h >= 0: the host refuses negative heights): the surface stays behind. kh h, its
         * product with ng_i and the sum round once each: within gamma(3) (|p_i| + |kh h ng_i|) per
         * coordinate, which also holds where the sum cancels (a point near the origin lifted across it) and
         * the result is smaller than what was rounded. */
        vfloat lift = kh * height;
        vec3 reach = v3_add(v3_abs(*p), v3_scale(v3_abs(ng), vabs(lift)));
        *p = v3_select(*p, v3_madd(*p, lift, ng), mask);
        *err = SELECT(*err, *err + GAMMA(3) * error_along(ng, reach), mask);
    }
#endif
    if (m->normal_map >= 0 || m->height_map >= 0) { /* the frame's normal seen from the ray's side */
        vfloat side = SELECT((vfloat)(1.0f), (vfloat)(-1.0f), v3_dot(frame_n, ng) < 0.0f);
        *n = v3_select(*n, v3_scale(shading, side), mask);
    }
}

#if HAS_LOOKUPS
/* Material m's textured parameters (Material.maps: lookups.cl) on the lanes of `mask`, at their hits h. A
 * textured roughness is kept within [1e-3, 1], the range of the constant one (raytrace/scene/bsdfs.py; below
 * 1e-3 the host renders a constant roughness with the smooth BSDF, packing.SMOOTH_ALPHA): an image's 0 would be
 * a delta density, which the microfacet terms cannot evaluate, and values above 1 were never tested. */
/* Lookup l at the hits h: lookups.cl's lookup_value at their (u, v), or a mesh attribute (Mitsuba's
 * mesh_attribute: a colour, for colour parameters only) interpolated over each lane's triangle with the hit's
 * barycentrics, times its scale. Lanes on other shapes get 0 (the host refuses such a material on them). */
inline vec3 lookup_at(const Scene *s, TextureStore ts, int l, const TexturedHits *h, int filter)
{
    __global const TextureLookup *t = &ts.lookups[l];
    if (t->kind != LOOKUP_MESH_ATTRIBUTE)
        return lookup_value(ts, l, h->surface.uv, h->duv, filter);
    int kind[LANES], index[LANES];
    float b1[LANES], b2[LANES];
    VSTORE(h->kind, kind);
    VSTORE(h->index, index);
    VSTORE(h->b1, b1);
    VSTORE(h->b2, b2);
    Lanes3 values = v3_spill(v3_splat(0.0f, 0.0f, 0.0f));
    for (int i = 0; i < LANES; ++i) {
        if (kind[i] != SHAPE_TRIANGLE)
            continue;
        __global const TriangleAttribute *a = &s->attributes[t->attribute + index[i]];
        set_lane3(&values, i, (1.0f - b1[i] - b2[i]) * f3(a->a0) + b1[i] * f3(a->a1) + b2[i] * f3(a->a2));
    }
    return v3_scale(v3_fill(&values), t->scale);
}

#if HAS_PERTURBED_NORMALS
/* Material m's normalmap, bumpmap or both on the lanes of `mask`, as Mitsuba 3's wrappers perturb the shading frame
 * (src/bsdfs/normalmap.cpp, bumpmap.cpp): the frame (s, t, n0) of the shading normal n0, facing the shape's
 * outside, and s along dp/du made orthogonal to it; a normal map's rgb is (x, y, z) / 2 + 1/2 in that frame; a
 * bump map's gradient g (times bump_scale) tilts dp/du and dp/dv out of the tangent plane, dp/du + n0 (g.x -
 * n0.dp/du), and the normal is their cross product, on the geometric normal's side; with both (Mitsuba's
 * bumpmap around a normalmap, bumpmap.cpp's frame passed to the normalmap inside), the normal map's frame is the
 * bump's: its normal, and s along its tilted dp/du. Where the viewer wo would
 * lie on different sides of n0 and of the perturbed normal, its tangential part is mirrored (Mitsuba's
 * flip_invalid_normals). sp->n becomes the perturbed normal, on sp->n0's side of the viewer (mirrored through the
 * surface on a back hit of mirrored_maps); sp->n0 keeps the shading normal for bsdf.cl's side condition and
 * shadow terminator. */
inline void perturb_normal(const Scene *s, TextureStore ts, __global const Material *m, int filter,
                           const TexturedHits *h, vint mask, vec3 wo, ShadingPoint *sp)
{
    vec3 outside = v3(h->surface.n.x, h->surface.n.y, h->surface.n.z);
    vfloat side = SELECT((vfloat)(1.0f), (vfloat)(-1.0f), v3_dot(sp->n, outside) < 0.0f);
    vec3 n0 = v3_scale(sp->n, side); /* the shading normal, facing out */
    vec3 dpdu = h->surface.dpdu, dpdv = h->surface.dpdv, n = n0;
    if (m->maps[MAP_BUMP] >= 0) { /* with both maps, Mitsuba's bumpmap around a normalmap: the bump first */
        vec2 g = lookup_gradient(ts, m->maps[MAP_BUMP], h->surface.uv);
        vec3 du = v3_madd(dpdu, m->bump_scale * g.x - v3_dot(n0, dpdu), n0);
        vec3 dv = v3_madd(dpdv, m->bump_scale * g.y - v3_dot(n0, dpdv), n0);
        n = v3_unit_or(v3_cross(du, dv), n0);
        n = v3_scale(n, SELECT((vfloat)(1.0f), (vfloat)(-1.0f), v3_dot(n, outside) < 0.0f));
        dpdu = du; /* the bumped frame's s, which a normal map inside it takes */
    }
    if (m->maps[MAP_NORMAL] >= 0) { /* in the frame (s, t, n) of the normal so far */
        vec3 c = lookup_at(s, ts, m->maps[MAP_NORMAL], h, filter);
        vec3 s = v3_unit_or(v3_sub(dpdu, v3_scale(n, v3_dot(n, dpdu))), any_perpendicular(n));
        vec3 t = v3_cross(n, s);
        vec3 mapped = v3_scale(s, MAD(c.x, 2.0f, -1.0f));
        mapped = v3_madd(mapped, MAD(c.y, 2.0f, -1.0f), t);
        n = v3_unit_or(v3_madd(mapped, MAD(c.z, 2.0f, -1.0f), n), n);
    }
    /* Mitsuba's twosided around the map turns the directions over (z -> -z) before the map perturbs them: its
     * back sees the map's normal mirrored through the surface, on the viewer's side, where a map around twosided
     * turns it whole (side n) */
    vint through = m->mirrored_maps ? side < 0.0f : (vint)(0);
    n = v3_select(n, v3_madd(n, -2.0f * v3_dot(n, n0), n0), through);
    vfloat cos_n = v3_dot(n, n0);
    vec3 mirrored = v3_sub(v3_scale(n0, 2.0f * cos_n), n);
    vfloat cos_wo = v3_dot(wo, n0) * SELECT((vfloat)(1.0f), (vfloat)(-1.0f), through); /* the map's frame's */
    n = v3_select(n, mirrored, cos_wo * v3_dot(wo, n) <= 0.0f);
    sp->n0 = v3_select(sp->n0, sp->n, mask);
    sp->n = v3_select(sp->n, v3_select(v3_scale(n, side), n, through), mask);
    sp->perturbed = SELECT(sp->perturbed, (vint)(-1), mask);
}
#endif

#if HAS_PRINCIPLED_LOOKUPS
/* principled's textured weights (MAP_ROUGHNESS .. MAP_SPEC_TRANS, and principledthin's MAP_FLATNESS ..
 * MAP_PRINCIPLED_ETA: a float each, a lookup's luminance or mean), clamped to their ranges, [0, 1] but
 * diff_trans's [0, 2] and eta's [2^-16, 2^16] (the host refuses textures beyond them; this catches the filters'
 * last rounding), and the terms the host derives from them per material (principled_terms.py) derived here per
 * lane in the same float32 operations, so that a constant texture gives the constant parameter's values bit for
 * bit: the clearcoat's GTR1 roughness lerp(0.1, 0.001, clearcoat_gloss) as Dr.Jit's lerp, 0.001 t + (0.1 - 0.1
 * t); where roughness or anisotropic is textured the main lobe's alphas, Mitsuba's calc_dist_params with
 * has_anisotropic (a textured parameter is given: aspect = sqrt(1 - 0.9 anisotropic) is 1 exactly at anisotropic
 * 0, the isotropic alpha): alpha_u = max(1e-3, roughness^2 / aspect), alpha_v = max(1e-3, roughness^2 aspect);
 * and where either or principledthin's eta is textured, its transmission's, of (0.65 eta - 0.35) roughness. No
 * contraction into fmas, which the host's numpy does not do; sqrt and the division are correctly rounded where
 * the device's are (pocl's CPU; OpenCL allows 3 and 2.5 ulp without -cl-fp32-correctly-rounded-divide-sqrt). */
inline void principled_lookups(TextureStore ts, __global const Material *m, int filter, const TexturedHits *h,
                               vint mask, ShadingPoint *sp)
{
#pragma OPENCL FP_CONTRACT OFF
    const vfloat zero = 0.0f, one = 1.0f;
#define PRINCIPLED_LOOKUP(slot, value, derive)                                                                    \
    if (m->maps[MAP_##slot] >= 0) {                                                                              \
        vfloat t = vmin(vmax(lookup_value(ts, m->maps[MAP_##slot], h->surface.uv, h->duv, filter).x, zero), one); \
        sp->principled[PRINCIPLED_##value] = SELECT(sp->principled[PRINCIPLED_##value], (derive), mask);          \
    }
    PRINCIPLED_LOOKUP(ROUGHNESS, ROUGHNESS, t)
    PRINCIPLED_LOOKUP(ANISOTROPIC, ANISOTROPIC, t)
    PRINCIPLED_LOOKUP(METALLIC, METALLIC, t)
    PRINCIPLED_LOOKUP(SPEC_TINT, SPEC_TINT, t)
    PRINCIPLED_LOOKUP(SHEEN, SHEEN, t)
    PRINCIPLED_LOOKUP(SHEEN_TINT, SHEEN_TINT, t)
    PRINCIPLED_LOOKUP(CLEARCOAT, CLEARCOAT, t)
    PRINCIPLED_LOOKUP(CLEARCOAT_GLOSS, CLEARCOAT_ALPHA, 0.001f * t + (0.1f - 0.1f * t))
    PRINCIPLED_LOOKUP(SPEC_TRANS, SPEC_TRANS, t)
    PRINCIPLED_LOOKUP(FLATNESS, FLATNESS, t)
#undef PRINCIPLED_LOOKUP
    if (m->maps[MAP_DIFF_TRANS] >= 0) { /* in [0, 2], halved */
        vfloat t = vmin(vmax(lookup_value(ts, m->maps[MAP_DIFF_TRANS], h->surface.uv, h->duv, filter).x, zero), 2.0f);
        sp->principled[PRINCIPLED_DIFF_TRANS] = SELECT(sp->principled[PRINCIPLED_DIFF_TRANS], t / 2.0f, mask);
    }
    if (m->maps[MAP_PRINCIPLED_ETA] >= 0) { /* in [2^-16, 2^16], as the host holds it */
        vfloat e = lookup_value(ts, m->maps[MAP_PRINCIPLED_ETA], h->surface.uv, h->duv, filter).x;
        sp->eta.x = SELECT(sp->eta.x, vmin(vmax(e, 0x1p-16f), 0x1p16f), mask);
    }
    const int rough = m->maps[MAP_ROUGHNESS] >= 0 || m->maps[MAP_ANISOTROPIC] >= 0;
    const int thin = m->bsdf == BSDF_PRINCIPLEDTHIN && (rough || m->maps[MAP_PRINCIPLED_ETA] >= 0);
    if (!rough && !thin)
        return;
    vfloat aspect = sqrt(1.0f - 0.9f * sp->principled[PRINCIPLED_ANISOTROPIC]);
    if (rough) {
        vfloat r = sp->principled[PRINCIPLED_ROUGHNESS], r2 = r * r;
        sp->alpha = SELECT(sp->alpha, vmax((vfloat)(1e-3f), r2 / aspect), mask);
        sp->alpha_v = SELECT(sp->alpha_v, vmax((vfloat)(1e-3f), r2 * aspect), mask);
    }
    if (thin) { /* the transmission's, of the roughness scaled by 0.65 eta - 0.35 (principled_terms.py) */
        vfloat r = (0.65f * sp->eta.x - 0.35f) * sp->principled[PRINCIPLED_ROUGHNESS], r2 = r * r;
        sp->principled[PRINCIPLED_TRANS_ALPHA_U] = SELECT(sp->principled[PRINCIPLED_TRANS_ALPHA_U],
                                                          vmax((vfloat)(1e-3f), r2 / aspect), mask);
        sp->principled[PRINCIPLED_TRANS_ALPHA_V] = SELECT(sp->principled[PRINCIPLED_TRANS_ALPHA_V],
                                                          vmax((vfloat)(1e-3f), r2 * aspect), mask);
    }
}
#endif

#if HAS_CONDUCTORS || HAS_ROUGH_CONDUCTORS
inline vec3 non_negative(vec3 a) { return v3(vmax(a.x, 0.0f), vmax(a.y, 0.0f), vmax(a.z, 0.0f)); }
#endif

inline void lookup_material(const Scene *s, TextureStore ts, __global const Material *m, int filter,
                            const TexturedHits *h, vint mask, vec3 wo, ShadingPoint *sp)
{
#if HAS_PERTURBED_NORMALS
    if (m->maps[MAP_NORMAL] >= 0 || m->maps[MAP_BUMP] >= 0)
        perturb_normal(s, ts, m, filter, h, mask, wo, sp);
#endif
    if (m->maps[MAP_COLOUR] >= 0)
        sp->k = v3_select(sp->k, lookup_at(s, ts, m->maps[MAP_COLOUR], h, filter), mask);
#if HAS_CONDUCTORS || HAS_ROUGH_CONDUCTORS
    /* (the host refuses negative values, images' and checkerboards' and a read mesh attribute's: a backstop) */
    if (m->maps[MAP_ETA] >= 0)
        sp->eta = v3_select(sp->eta, non_negative(lookup_at(s, ts, m->maps[MAP_ETA], h, filter)), mask);
    if (m->maps[MAP_K] >= 0)
        sp->k_imag = v3_select(sp->k_imag, non_negative(lookup_at(s, ts, m->maps[MAP_K], h, filter)), mask);
#endif
#if HAS_COATS
    if (m->maps[MAP_SPECULAR] >= 0)
        sp->specular = v3_select(sp->specular, lookup_at(s, ts, m->maps[MAP_SPECULAR], h, filter),
                                 mask);
#endif
#if HAS_MICROFACETS
    if (m->maps[MAP_ALPHA] >= 0) {
        vfloat a = lookup_at(s, ts, m->maps[MAP_ALPHA], h, filter).x;
        sp->alpha = SELECT(sp->alpha, vmin(vmax(a, 1e-3f), 1.0f), mask);
    }
    if (m->maps[MAP_ALPHA_V] >= 0) {
        vfloat a = lookup_at(s, ts, m->maps[MAP_ALPHA_V], h, filter).x;
        sp->alpha_v = SELECT(sp->alpha_v, vmin(vmax(a, 1e-3f), 1.0f), mask);
    }
#endif
#if HAS_PRINCIPLED_LOOKUPS
    principled_lookups(ts, m, filter, h, mask, sp);
#endif
}
#endif

#endif

#if HAS_WRAPPERS
#include "wrappers.cl"
#endif

#if HAS_NULLS
/* The lanes of `hit` (a shadow segment's crossing, primitive.cl) whose material there is `null`: its
 * wrappers resolved as a ray meeting the surface resolves them, with the scene's textures for textured
 * opacities and weights. */
vint passes_through(const Scene *s, Ray r, Hit hit)
{
#if HAS_WRAPPERS
    hit.material = wrapped_materials(s, s->textures, r, hit);
#endif
    int m[LANES], null[LANES];
    VSTORE(hit.material, m);
    for (int i = 0; i < LANES; ++i)
        null[i] = m[i] >= 0 && s->materials[m[i]].bsdf == BSDF_NULL;
    return VLOAD_INT(null) != 0;
}
#endif

#if HAS_SMOOTH_NORMALS
/* The shading normal of a smooth triangle at barycentrics (b1, b2): its corner normals interpolated (Phong
 * shading of normals). They lie on the side of the face's own normal (the mesh's winding, kept
 * counter-clockwise from the front on load), so they are turned as the facing normal ng was turned from it.
 * Where they cancel (back-to-back faces sharing vertices), ng itself. */
inline float3 smooth_normal(const Scene *s, int index, int instance, float b1, float b2, float3 ng)
{
    __global const TriangleNormals *c = &s->triangle_normals[index];
    float3 n = (1.0f - b1 - b2) * f3(c->n0) + b1 * f3(c->n1) + b2 * f3(c->n2), face = f3(s->triangles[index].normal);
#if HAS_INSTANCES
    if (instance >= 0) { /* a group's normals, placed by the instance's inverse transpose */
        n = mat3_mul_transposed(s->instances[instance].to_local, n);
        face = mat3_mul_transposed(s->instances[instance].to_local, face);
    }
#endif
    float side = dot3(face, ng) < 0.0f ? -1.0f : 1.0f;
    return dot3(n, n) > 0.0f ? normalize3(n) * side : ng;
}
#endif

#if HAS_ANISOTROPIC
/* sp with its shading tangent t (anisotropic BSDFs' x axis): the direction of dp/du at each lane's hit made
 * orthogonal to the shading normal, Mitsuba 3's shading frame (SurfaceInteraction::initialize_sh_frame:
 * s = normalize(dp_du - n dot(n, dp_du)), and coordinate_system(n) where dp/du vanishes). dp/du is a
 * rectangle's tangent (Mitsuba's rectangle: its local x axis), a triangle's from its uvs (TriangleUV.tangent:
 * a mesh without uvs has the barycentric uvs (b1, b2), dp/du = v1 - v0, as Mitsuba's mesh without texture
 * coordinates; degenerate uvs the face's coordinate system, as Mitsuba's), an ellipsoid's of its spherical
 * coordinates, M (-q.y, q.x, 0) at the unit-sphere point q (Mitsuba's sphere; 0 at the poles), a disk's and a
 * cylinder's surface_disk's and surface_cylinder's dp/du (Mitsuba's; a disk's is 0 at its centre). After the
 * normal and height maps: the tangent follows the normal they give (Mitsuba's normalmap builds its frame
 * from dp/du so). Lanes that hit nothing get some unit vector orthogonal to n. */
inline ShadingPoint with_tangent(const Scene *s, Hit hit, ShadingPoint sp)
{
    int kind[LANES], index[LANES];
    VSTORE(hit.kind, kind);
    VSTORE(hit.index, index);
#if HAS_INSTANCES
    int instance[LANES];
    VSTORE(hit.instance, instance);
#endif
    Lanes3 p = v3_spill(hit.p), dpdu = v3_spill(v3_splat(0.0f, 0.0f, 0.0f));
    for (int i = 0; i < LANES; ++i) {
        float3 d = (float3)(0.0f);
        if (kind[i] == SHAPE_RECTANGLE)
            d = f3(s->rectangles[index[i]].tangent);
#if HAS_TRIANGLES
        if (kind[i] == SHAPE_TRIANGLE)
            d = f3(s->triangle_uvs[index[i]].tangent);
#endif
#if HAS_INSTANCES
        if (instance[i] >= 0) /* a group's triangle: its dp/du placed by the instance */
            d = mat3_mul(s->instances[instance[i]].to_world, d);
#endif
#if HAS_ELLIPSOIDS
        if (kind[i] == SHAPE_ELLIPSOID) {
            __global const Ellipsoid *e = &s->ellipsoids[index[i]];
            float3 q = mat3_mul(e->world_to_unit, lane3(&p, i) - f3(e->center));
            d = mat3_mul(e->unit_to_world, (float3)(-q.y, q.x, 0.0f));
        }
#endif
#if HAS_DISKS
        if (kind[i] == SHAPE_DISK)
            d = surface_disk(&s->disks[index[i]], lane3(&p, i)).dpdu;
#endif
#if HAS_CYLINDERS
        if (kind[i] == SHAPE_CYLINDER)
            d = surface_cylinder(&s->cylinders[index[i]], lane3(&p, i)).dpdu;
#endif
        set_lane3(&dpdu, i, d);
    }
    vec3 d = v3_fill(&dpdu);
    sp.t = v3_unit_or(v3_sub(d, v3_scale(sp.n, v3_dot(sp.n, d))), any_perpendicular(sp.n));
    return sp;
}
#else
#define with_tangent(s, hit, sp) (sp)
#endif

/* The shading point of each lane's hit along r: the material's per lane (a gather), then each textured
 * material's textures on the lanes that hit it, lane-parallel. */
inline ShadingPoint shading_point(const Scene *s, TextureStore ts, Ray r, Hit hit)
{
#if HAS_WRAPPERS
    hit.material = wrapped_materials(s, ts, r, hit);
#endif
    ShadingPoint sp;
    sp.p = hit.p;
    sp.err = hit.err;
#if HAS_NULLS
    sp.passes = (vint)(0);
#endif
    sp.ng = sp.n = hit.n;
    int m[LANES];
    float sh[LANES];
    Lanes3 k = v3_spill(v3_splat(0.0f, 0.0f, 0.0f));
    VSTORE(hit.material, m);
#if HAS_BSDF_PARAMETERS
    int bsdf[LANES];
    float alpha[LANES];
    Lanes3 eta = v3_spill(v3_splat(0.0f, 0.0f, 0.0f)), k_imag = eta;
#endif
#if HAS_MICROFACETS
    int distribution[LANES];
    float alpha_v[LANES];
#endif
#if HAS_COATS
    int nonlinear[LANES];
    float internal_reflectance[LANES], specular_weight[LANES];
    Lanes3 specular = v3_spill(v3_splat(0.0f, 0.0f, 0.0f));
#endif
#if HAS_ROUGH_PLASTICS
    sp.material = hit.material;
    sp.materials = s->materials;
#endif
#if HAS_BACKFACES
    sp.backface = hit.backface;
#endif
#if HAS_PERTURBED_NORMALS
    sp.perturbed = (vint)(0);
#endif
#if HAS_SMOOTH_NORMALS /* the hits' shapes and barycentrics, for interpolating normals per lane */
    int kind[LANES], index[LANES];
    float b1[LANES], b2[LANES];
    VSTORE(hit.kind, kind);
    VSTORE(hit.index, index);
    VSTORE(hit.b1, b1);
    VSTORE(hit.b2, b2);
    Lanes3 n = v3_spill(sp.n);
    int instance[LANES];
#if HAS_INSTANCES
    VSTORE(hit.instance, instance);
#else
    for (int i = 0; i < LANES; ++i)
        instance[i] = -1;
#endif
#endif
#if HAS_TEXTURES
    int textured[LANES], any_textured = 0;
#endif
#if HAS_PRINCIPLED_VALUES
    float principled[PRINCIPLED_PARAMETERS][LANES];
#endif
    for (int i = 0; i < LANES; ++i) {
        sh[i] = 1.0f;
#if HAS_BSDF_PARAMETERS
        bsdf[i] = BSDF_DIFFUSE;
        alpha[i] = 1.0f;
#endif
#if HAS_MICROFACETS
        distribution[i] = MICROFACET_GGX;
        alpha_v[i] = 1.0f;
#endif
#if HAS_COATS
        nonlinear[i] = 0;
        internal_reflectance[i] = specular_weight[i] = 0.0f;
#endif
#if HAS_TEXTURES
        textured[i] = m[i] >= 0 && is_textured(&s->materials[m[i]]);
        any_textured |= textured[i];
#endif
#if HAS_PRINCIPLED_VALUES
        for (int j = 0; j < PRINCIPLED_PARAMETERS; ++j)
            principled[j][i] = m[i] < 0 ? 0.0f : s->materials[m[i]].principled[j];
#endif
        if (m[i] < 0)
            continue;
        __global const Material *mat = &s->materials[m[i]];
        sh[i] = mat->shininess;
        set_lane3(&k, i, f3(mat->colour));
#if HAS_BSDF_PARAMETERS
        bsdf[i] = mat->bsdf;
        alpha[i] = mat->alpha;
        set_lane3(&eta, i, f3(mat->eta));
        set_lane3(&k_imag, i, f3(mat->k));
#endif
#if HAS_MICROFACETS
        distribution[i] = mat->distribution;
        alpha_v[i] = mat->alpha_v;
#endif
#if HAS_COATS
        nonlinear[i] = mat->nonlinear;
        internal_reflectance[i] = mat->internal_reflectance;
        specular_weight[i] = mat->specular_weight;
        set_lane3(&specular, i, f3(mat->specular));
#endif
#if HAS_SMOOTH_NORMALS
        /* a normal or height map defines its own shading normal, from the flat frame (a known limit) */
        if (kind[i] == SHAPE_TRIANGLE && mat->normal_map < 0 && mat->height_map < 0)
            set_lane3(&n, i, smooth_normal(s, index[i], instance[i], b1[i], b2[i], lane3(&n, i)));
#endif
    }
    sp.k = v3_fill(&k);
    sp.shininess = VLOAD(sh);
#if HAS_BSDF_PARAMETERS
    sp.bsdf = VLOAD_INT(bsdf);
    sp.eta = v3_fill(&eta);
    sp.k_imag = v3_fill(&k_imag);
    sp.alpha = VLOAD(alpha);
#endif
#if HAS_MICROFACETS
    sp.distribution = VLOAD_INT(distribution);
    sp.alpha_v = VLOAD(alpha_v);
#endif
#if HAS_COATS
    sp.nonlinear = VLOAD_INT(nonlinear);
    sp.internal_reflectance = VLOAD(internal_reflectance);
    sp.specular_weight = VLOAD(specular_weight);
    sp.specular = v3_fill(&specular);
#endif
#if HAS_PRINCIPLED_VALUES
    for (int j = 0; j < PRINCIPLED_PARAMETERS; ++j)
        sp.principled[j] = VLOAD(principled[j]);
#endif
#if HAS_SMOOTH_NORMALS
    sp.n = v3_fill(&n);
#endif
#if HAS_PERTURBED_NORMALS
    sp.n0 = sp.n;
#endif
#if HAS_TEXTURES
    if (!any_textured)
        return with_tangent(s, hit, sp);
    TexturedHits h = textured_hits(s, hit, textured_surface(s, hit, textured), r.d, sp.p, sp.ng);
    for (int i = 0; i < LANES; ++i) {
        if (!textured[i])
            continue;
        int first = 1; /* each material once, at its first lane */
        for (int j = 0; j < i; ++j)
            first &= m[j] != m[i];
        if (!first)
            continue;
        texture_material(ts, &s->materials[m[i]], s->params->texture_filter, &h, hit.material == m[i], sp.ng,
                         &sp.k, &sp.n, &sp.p, &sp.err);
#if HAS_LOOKUPS
        lookup_material(s, ts, &s->materials[m[i]], s->params->texture_filter, &h, hit.material == m[i],
                        v3_scale(r.d, -1.0f), &sp);
#endif
    }
#endif
    return with_tangent(s, hit, sp);
}

#endif
