/* The material at a hit: its colour (the material's, or its colour map's), shininess, and where and with
 * which normal it is shaded (normal map, bump map and displacement: the README's Textures section).
 *
 * Without textures (HAS_TEXTURES 0) this is a gather of the material table; with them, every lane runs
 * the scalar texturing code below for its own hit. */
#ifndef MATERIAL_CL
#define MATERIAL_CL

#include "intersect.cl"
#if HAS_TEXTURES
#include "camera.cl"
#include "mipmap.cl"
#include "surface.cl"
#endif

typedef struct {
    vec3 p;            /* the shading point: the hit, displaced by a height map */
    vfloat err;        /* a bound on p's distance from the surface, or from where the height map puts it */
    vec3 ng;           /* geometric unit normal, facing the incoming ray */
    vec3 n;            /* shading unit normal, on the side of ng */
    vec3 k;            /* the material's colour at the hit (0 where no surface was hit) */
    vfloat shininess;
} ShadingPoint;

#if HAS_TEXTURES

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
    return surface_rectangle(&s->rectangles[index], p);
}

/* The height map's bump: the shading normal of the surface displaced by h along n, from the partial
 * derivatives dh_du, dh_dv (scene units per unit of u and v), without forming the displaced dp/du x dp/dv
 * (pbrt-v4 section 10.5.1), which loses the u direction where dp/du vanishes (an ellipsoid's pole):
 * (dpdu + dh_du n) x (dpdv + dh_dv n) is a multiple of n - grad h, grad h = dh_du e_u + dh_dv e_v with the
 * dual basis e_u = (dpdv x n) / a, e_v = (n x dpdu) / a, a = n.(dpdu x dpdv). Where a is 0, n is kept. */
inline float3 bump_normal(float3 dpdu, float3 dpdv, float3 n, float dh_du, float dh_dv)
{
    float a = dot3(n, cross3(dpdu, dpdv));
    float3 bumped = normalize3(n - (cross3(dpdv, n) * dh_du + cross3(n, dpdu) * dh_dv) / a);
    return finite3(bumped) ? bumped : n;
}

/* Everything textured about one lane's hit: *k, *n (starts as the facing geometric normal ng), *p and its
 * error bound *err (ray.h). */
inline void texture_lane(const Scene *s, TextureStore ts, __global const Material *m, int kind, int index,
                         float b1, float b2, float3 d, float3 *k, float3 *n, float3 *p, float *err)
{
    __constant const RenderParams *params = s->params;
    SurfacePoint sp = surface_point(s, kind, index, *p, b1, b2);
    float3 dpdx, dpdy;
    camera_footprint(s->camera, params->footprint_scale, 1.0f / params->width, 1.0f / params->height, d, *p, *n,
                     &dpdx, &dpdy);
    /* the material's uv transform, then (s, t) = (u, 1 - v) of the image */
    float2 scale = (float2)(m->uv_scale[0], m->uv_scale[1]);
    float2 uv = sp.uv * scale + (float2)(m->uv_offset[0], m->uv_offset[1]);
    float4 duv = uv_derivatives(sp, dpdx, dpdy) * scale.xyxy;
    float2 st = (float2)(uv.x, 1.0f - uv.y);
    float4 dst = duv * (float4)(1.0f, -1.0f, 1.0f, -1.0f);
    const int filter = params->texture_filter, wrap = m->wrap;
    float3 ng = *n;
    Frame frame = shading_frame(sp);
    float side = dot3(frame.n, ng) < 0.0f ? -1.0f : 1.0f; /* the frame's normal seen from the ray's side */
    float3 shading = frame.n;
#if HAS_COLOUR_MAPS
    if (m->colour_map >= 0)
        *k = texture_lookup(ts, m->colour_map, st, dst, filter, wrap).xyz;
#endif
#if HAS_NORMAL_MAPS
    if (m->normal_map >= 0) { /* tangent space: rgb = (x, y, z) / 2 + 1/2 */
        float3 c = texture_lookup(ts, m->normal_map, st, dst, filter, wrap).xyz * 2.0f - 1.0f;
        float3 mapped = normalize3(frame.t * c.x + frame.b * c.y + frame.n * c.z);
        shading = finite3(mapped) ? mapped : frame.n;
    }
#endif
#if HAS_HEIGHT_MAPS
    if (m->height_map >= 0) {
        MipLevel top = mip_level(ts, m->height_map, 0);
        float du = max1(0.5f * (abs1(duv.x) + abs1(duv.z)), 0.5f / top.width);
        float dv = max1(0.5f * (abs1(duv.y) + abs1(duv.w)), 0.5f / top.height);
        float h = texture_lookup(ts, m->height_map, st, dst, filter, wrap).x;
        float hu = texture_lookup(ts, m->height_map, st + (float2)(du, 0.0f), dst, filter, wrap).x;
        float hv = texture_lookup(ts, m->height_map, st - (float2)(0.0f, dv), dst, filter, wrap).x;
        float kh = m->height_scale;
        shading = bump_normal(sp.dpdu / scale.x, sp.dpdv / scale.y, shading, kh * (hu - h) / du,
                              kh * (hv - h) / dv);
        *p += ng * (kh * h); /* outwards (kh h >= 0): the surface stays behind; the sum rounds once more */
        *err += GAMMA(2) * dot3(abs3(ng), abs3(*p));
    }
#endif
    *n = shading * side;
}

#endif

#if HAS_SMOOTH_NORMALS
/* The shading normal of a smooth triangle at barycentrics (b1, b2): its corner normals interpolated (Phong
 * shading of normals). They lie on the side of the face's own normal (the mesh's winding, kept
 * counter-clockwise from the front on load), so they are turned as the facing normal ng was turned from it.
 * Where they cancel (back-to-back faces sharing vertices), ng itself. */
inline float3 smooth_normal(const Scene *s, int index, float b1, float b2, float3 ng)
{
    __global const TriangleNormals *c = &s->triangle_normals[index];
    float3 n = (1.0f - b1 - b2) * f3(c->n0) + b1 * f3(c->n1) + b2 * f3(c->n2);
    float side = dot3(f3(s->triangles[index].normal), ng) < 0.0f ? -1.0f : 1.0f;
    return dot3(n, n) > 0.0f ? normalize3(n) * side : ng;
}
#endif

/* The shading point of each lane's hit along r. */
inline ShadingPoint shading_point(const Scene *s, TextureStore ts, Ray r, Hit hit)
{
    ShadingPoint sp;
    sp.p = hit.p;
    sp.err = hit.err;
    sp.ng = sp.n = hit.n;
    int m[LANES];
    float sh[LANES];
    Lanes3 k = v3_spill(v3_splat(0.0f, 0.0f, 0.0f));
    VSTORE(hit.material, m);
#if HAS_SURFACE_DATA
    int kind[LANES], index[LANES];
    float b1[LANES], b2[LANES];
    VSTORE(hit.kind, kind);
    VSTORE(hit.index, index);
    VSTORE(hit.b1, b1);
    VSTORE(hit.b2, b2);
    Lanes3 n = v3_spill(sp.n);
#endif
#if HAS_TEXTURES
    Lanes3 p = v3_spill(sp.p), d = v3_spill(r.d);
    float err[LANES];
    VSTORE(sp.err, err);
#endif
    for (int i = 0; i < LANES; ++i) {
        sh[i] = 1.0f;
        if (m[i] < 0)
            continue;
        __global const Material *mat = &s->materials[m[i]];
        sh[i] = mat->shininess;
        float3 colour = f3(mat->colour);
#if HAS_SURFACE_DATA
        float3 ng = lane3(&n, i);
#endif
#if HAS_TEXTURES
        float3 pi = lane3(&p, i), ni = ng;
        texture_lane(s, ts, mat, kind[i], index[i], b1[i], b2[i], lane3(&d, i), &colour, &ni, &pi, &err[i]);
        set_lane3(&p, i, pi);
        set_lane3(&n, i, ni);
#endif
#if HAS_SMOOTH_NORMALS
        /* a normal or height map defines its own shading normal, from the flat frame (a known limit) */
        if (kind[i] == SHAPE_TRIANGLE && mat->normal_map < 0 && mat->height_map < 0)
            set_lane3(&n, i, smooth_normal(s, index[i], b1[i], b2[i], ng));
#endif
        set_lane3(&k, i, colour);
    }
    sp.k = v3_fill(&k);
    sp.shininess = VLOAD(sh);
#if HAS_SURFACE_DATA
    sp.n = v3_fill(&n);
#endif
#if HAS_TEXTURES
    sp.p = v3_fill(&p);
    sp.err = VLOAD(err);
#endif
    return sp;
}

#endif
