/* Global illumination, the third shading model (`shading = "path"`; docs/global-illumination.md):
 * unidirectional path tracing from the camera (pbrt-v4's PathIntegrator, Mitsuba 3's `path`). A material's
 * BSDF is its `type`, with Mitsuba's names (docs/bsdfs.md), reached only through bsdf.cl's interface: its value
 * and density towards a direction (bsdf_eval_pdf) and its own sample of one (bsdf_sample). The rectangular
 * lights emit their radiance from the front face and reflect by their material where they have one; an
 * environment (HAS_ENVIRONMENT, environment.cl), constant or an image, emits along every direction in which a
 * ray leaves the scene.
 *
 * At every vertex the lights are sampled by area (next-event estimation, light_sampling.cl) and the BSDF by
 * its own sample; the two estimates of light reached both ways are combined by multiple importance sampling
 * with the power heuristic (Veach, "Robust Monte Carlo Methods for Light Transport Simulation", 1997, section
 * 9.2), and so are the environment's, sampled by its map or, constant, by the cosine about the normal. Each
 * light's n samples form one technique and the BSDF's single sample the other: w_light = (n p_light)^2 / ((n
 * p_light)^2 + p_bsdf^2), both densities per solid angle, p_light = r^2 / (A cos(theta_l)), p_bsdf the
 * density of the BSDF's sample (bsdf_eval_pdf's). The weights are formed from the ratio p_bsdf / (n
 * p_light), which stays finite where either density does not (a light seen edge-on). A delta lobe's direction
 * (a mirror's, glass's, a smooth plastic's coat's) no light sample can meet, nor one through the surface
 * (lights are sampled on the side the vertex is seen from): light such a sample reaches counts whole, and a
 * BSDF of delta lobes only (bsdf_is_delta) takes no light samples. The tests check these weights against
 * path tracers of their own that sample the lights alone and the BSDF alone (tests/path_support.py).
 *
 * Depth follows Mitsuba's convention: max_depth 1 shows the emitters seen directly, 2 adds direct light, -1
 * is unbounded. From vertex rr_depth on (Mitsuba's default 5), after the vertex's light samples, Russian
 * roulette continues a path with probability q = min(max(throughput), 0.95) and divides its throughput by q
 * (pbrt-v4 section 13.1.1). */
#ifndef PATH_TRACING_CL
#define PATH_TRACING_CL

#include "vmath.h"
#include "bsdf.cl"
#include "warp.cl"
#include "mis.cl"
#include "roulette.cl"
/* The light samples' weights are colours, the BSDF's value (bsdf.cl) with its colour: light_sampling.cl sums
 * them as such. */
#define LIGHT_VALUE_VEC3 1
#ifndef LIGHT_SOLID_ANGLE
/* Lights are sampled by area. A build with 1 samples them by the solid angle they subtend where that is
 * accurate (spherical_rectangle.cl): its images are less noisy at the same samples, but each sample costs
 * more, and to the same error it took longer (measured in docs/global-illumination.md, from the records in
 * benchmarks/results/solid-angle/), so the renderer leaves it off; the tests keep it correct. */
#define LIGHT_SOLID_ANGLE 0
#endif

/* A light sample counts where it lies above the surface (ng and the shading normal n) and in front of the
 * light (direct_lighting.cl's rule). */
inline vint sample_counts(ShadingPoint sp, vec3 l, vec3 light_normal)
{
    return (v3_dot(sp.ng, l) > 0.0f) & (v3_dot(sp.n, l) > 0.0f) & (v3_dot(light_normal, l) < 0.0f);
}


/* The model's sample_weight takes the solid angle light_sampling.cl sampled the light by (0: by area). */
#if LIGHT_SOLID_ANGLE
#define SOLID_ANGLE_PARAMETER , vfloat solid_angle
#define SOLID_ANGLE_BY_AREA
#else
#define SOLID_ANGLE_PARAMETER
#define SOLID_ANGLE_BY_AREA const vfloat solid_angle = 0.0f;
#endif

/* 1 / (A p_light), A the light's area and p_light the density per steradian of a light's sample towards l:
 * cos(theta_l) / r^2 by area, the solid angle over A where the light was sampled by it (solid_angle > 0). */
inline vfloat light_area_weight(vfloat cos_l, vfloat r2, float area, vfloat solid_angle)
{
#if LIGHT_SOLID_ANGLE
    return SELECT(cos_l / r2, solid_angle / area, solid_angle > 0.0f);
#else
    return cos_l / r2;
#endif
}

/* The light sample's f cos(theta_s) / (A p_light) (bsdf.cl's value), times its MIS weight against the BSDF's
 * own sample of the direction: x = p_bsdf / (n p_light). */
inline vec3 sample_weight(ShadingPoint sp, vec3 w, vec3 l, vec3 light_normal, vec3 v, float area, int n,
                          vint active SOLID_ANGLE_PARAMETER)
{
    SOLID_ANGLE_BY_AREA
    vfloat pdf, g = light_area_weight(-v3_dot(light_normal, l), v3_dot(w, w), area, solid_angle);
    vec3 value = v3_scale(bsdf_eval_pdf(sp, v, l, active, &pdf), g);
    return v3_scale(value, power_weight(pdf * g * (area / (float)n)));
}

inline float light_scale(__global const Light *light) { return 4.0f * light->shape.half_x * light->shape.half_y; }

#if HAS_EMITTERS
/* An emitter's sample (emitters.cl): f cos(theta_s) / p_light, p_light its density per solid angle, times its
 * MIS weight against the BSDF's own sample of the direction: x = p_bsdf / (n p_light); 1 for a delta light, which
 * no BSDF sample meets. */
inline vec3 emitter_weight(ShadingPoint sp, vec3 l, vec3 v, vfloat pdf, int n, vint active, vint delta)
{
    vfloat pdf_b;
    vec3 value = bsdf_eval_pdf(sp, v, l, active, &pdf_b);
    return v3_scale(value, SELECT(power_weight(pdf_b / ((float)n * pdf)), (vfloat)(1.0f), delta) / pdf);
}
#endif

#include "light_sampling.cl"
#if HAS_ENVIRONMENT
#include "environment.cl"
#endif



#if LIGHT_SOLID_ANGLE
/* The solid angle, seen from each lane's o, of the light each lane's hit is on where light_sampling.cl samples
 * that light by solid angle from o, 0 elsewhere (by area, or no light hit). */
inline vfloat hit_light_solid_angle(const Scene *s, Hit hit, vec3 o)
{
    vfloat solid_angle = 0.0f;
    vint on_light = (hit.kind == SHAPE_NONE) & (hit.t < INFINITY);
    for (int li = 0; li < s->params->n_lights; ++li) {
        vint here = on_light & (hit.index == li);
        if (ANY(here)) {
            SphericalRectangle q = spherical_rectangle(&s->lights[li].shape, o);
            solid_angle = SELECT(solid_angle, q.solid_angle, here & spherical_rectangle_used(q));
        }
    }
    return solid_angle;
}
#endif


/* A path in each lane (pbrt-v4's PathIntegrator::Li, cut at its closest-hit call so that the lanes of a packet
 * may stand at different vertices: render.cl starts a lane's next pixel sample where its path ends): the ray
 * it follows next, from the camera (depth 0) or from its vertex `depth`, the throughput beta, the radiance
 * gathered so far, and what the MIS weight of light the ray reaches needs of the vertex it left: its BSDF
 * sample's density, whether no light sample could have met its direction (`specular`, weight 1: the camera's
 * ray, a delta lobe's, or a direction through the surface, since the lights and the environment are sampled on
 * the side the vertex is seen from only), and for a constant environment the sample's cosine (p_env = cos /
 * pi), for solid-angle light sampling the vertex. A pass through a see-through surface (a mask's `null`) is
 * no such vertex: the weights of light the ray reaches after it are those of the vertex before, whose light
 * samples pass the surface too (primitive.cl), and `travelled` is the distance from that vertex to the ray's
 * origin. */
typedef struct {
    Ray r;
    vec3 beta, radiance;
    vint depth, specular;
    vfloat pdf;
#if HAS_NULLS
    vfloat travelled;
    vint direct; /* no vertex yet, see-through passes alone: what the ray reaches the camera sees directly */
#endif
#if HAS_ENVIRONMENT
    vfloat cos_s;
#endif
#if LIGHT_SOLID_ANGLE || HAS_SHAPE_EMITTERS
    vec3 p; /* the vertex the ray left (the camera's rays: any value, their light counts whole) */
#endif
} PathState;

/* The paths of `lanes` start anew along the camera rays r. */
inline void start_paths(PathState *path, Ray r, vint lanes)
{
    path->r.o = v3_select(path->r.o, r.o, lanes);
    path->r.d = v3_select(path->r.d, r.d, lanes);
    path->beta = v3_select(path->beta, v3_splat(1.0f, 1.0f, 1.0f), lanes);
    path->radiance = v3_select(path->radiance, v3_splat(0.0f, 0.0f, 0.0f), lanes);
    path->depth = SELECT(path->depth, (vint)(0), lanes);
    path->specular = SELECT(path->specular, (vint)(-1), lanes) != 0; /* a mask, whatever the lane width */
    path->pdf = SELECT(path->pdf, (vfloat)(1.0f), lanes);
#if HAS_NULLS
    path->travelled = SELECT(path->travelled, (vfloat)(0.0f), lanes);
    path->direct = SELECT(path->direct, (vint)(-1), lanes) != 0;
#endif
}

/* The BSDF's and roulette's numbers: sobol's sequence, else independent points (a table pattern is a light's,
 * or the course's). */
inline Sampler bounce_sampler(const Scene *s)
{
    Sampler bounce = s->params->light_sampler;
    if (bounce.randomize != RANDOMIZE_SOBOL)
        bounce.randomize = RANDOMIZE_INDEPENDENT;
    return bounce;
}

/* The paths of `lanes` meet `hit` along their rays: the light and environment they reach, weighted against the
 * lights' samples of the same direction at the vertex they left (a camera ray's counts whole, max_depth 0
 * excepted). Returns the lanes whose hit is a vertex to shade: a surface, below max_depth. */
inline vint path_hit(const Scene *s, PathState *path, Hit hit, vint lanes)
{
    const int max_depth = s->params->max_depth, n_light = s->params->light_samples;
    const vec3 wi = path->r.d;
    const vint specular = path->specular;
    const vfloat pdf = path->pdf;
    /* light reached by the BSDF's sample, weighted against the lights' samples of the same direction: x = n
     * p_light / p_bsdf = n r^2 / (A cos(theta_l) p_bsdf) (0 where no light was hit: weight 1) */
    vfloat area = hit_light_area(s, hit), cos_l = vabs(v3_dot(hit.n, wi)), distance = hit.t;
#if HAS_NULLS
    distance += path->travelled;
    path->travelled = distance;
#endif
    vfloat x = (float)n_light * distance * distance / (area * cos_l * pdf);
#if LIGHT_SOLID_ANGLE
    vfloat solid_angle = hit_light_solid_angle(s, hit, path->p); /* p_light = 1 / solid_angle there */
    x = SELECT(x, (float)n_light / (solid_angle * pdf), solid_angle > 0.0f);
#endif
    vint weighed = area > 0.0f; /* a light was hit */
#if HAS_SHAPE_EMITTERS /* or an emitting shape: x = n p_light / p_bsdf, p_light per solid angle */
    vint on_emitter = lanes & (hit.emitter >= 0) & !specular;
    if (ANY(on_emitter))
        x = SELECT(x, (float)n_light * hit_emitter_pdf(s, hit, path->p, distance, cos_l, on_emitter) / pdf,
                   on_emitter);
    weighed |= on_emitter;
#endif
    vfloat w = SELECT((vfloat)(1.0f), power_weight(x), weighed & !specular);
    vint seen = max_depth != 0 ? lanes : (vint)(0); /* max_depth 0: nothing, not even the emitters */
    if (s->params->hide_emitters) { /* the emitters the camera sees, directly or through see-through surfaces,
                                     * are hidden (Mitsuba's path: its result counts only once a vertex other
                                     * than a null pass is met); render.cl's pass_emitters passed the lights */
#if HAS_NULLS
        seen &= !path->direct;
#else
        seen &= path->depth > 0;
#endif
    }
#if HAS_ENVIRONMENT
    vint escaped = seen & (hit.t == INFINITY);
    if (ANY(escaped)) { /* the environment reached by the BSDF's sample: x = p_env / p_bsdf, weight 1 after the
                         * camera or a specular vertex */
#if HAS_ENVIRONMENT_MAP
        vfloat pdf_e = environment_pdf(s, wi, escaped & !specular); /* (a camera ray's needs none) */
#else
        vfloat pdf_e = path->cos_s * M_1_PI_F;
#endif
        vfloat w_env = SELECT(power_weight(pdf_e / pdf), (vfloat)(1.0f), specular);
        vec3 e = v3_scale(v3_mul(path->beta, environment_radiance(s, wi, escaped)), w_env);
        path->radiance = v3_add(path->radiance, v3_select(v3_splat(0.0f, 0.0f, 0.0f), e, escaped));
    }
#endif
    vint lit = seen & (hit.t < INFINITY);
    path->radiance = v3_add(path->radiance, v3_select(v3_splat(0.0f, 0.0f, 0.0f),
                                                      v3_scale(v3_mul(path->beta, hit.emitted), w), lit));
    vint alive = lanes & (hit.t < INFINITY) & (hit.material >= 0);

    path->depth += 1; /* (a lane without a path is reset when it starts one) */
    return alive & (((vint)(max_depth < 0) != 0) | (path->depth < max_depth));
}

/* The paths of `alive` at their vertex, shaded at sp: the light sampled there (the lights, and the
 * environment), then the BSDF's sample of the direction onwards, which becomes the path's ray; *rays counts the
 * rays traced per lane. Returns the lanes whose path goes on: the BSDF's sample leaves the surface on its side. */
inline vint path_vertex(const Scene *s, TextureStore ts, PathState *path, ShadingPoint sp, vint alive,
                        __global const uint2 *light_samples, PixelSample *ps, vfloat *rays)
{
    const Sampler bounce = bounce_sampler(s);
    const Ray r = path->r;
#if HAS_NULLS
    /* a shadow ray may pass as many see-through surfaces as max_depth leaves vertices after its light's, since
     * Mitsuba counts each pass as a vertex (path_hit: a ray leaves vertex depth d while d < max_depth) */
    const int max_depth = s->params->max_depth;
    sp.passes = max_depth < 0 ? (vint)(INT_MAX) : (vint)(max_depth) - path->depth - 1;
#endif
    vec3 beta = path->beta, radiance = path->radiance;
    COUNT_VISITS_ADD(s, VISITS_PATH_LANES, count_lanes(alive));
    COUNT_VISITS_ADD(s, VISITS_PATH_LANE_STEPS, LANES);
    const vec3 wo = v3_scale(r.d, -1.0f);
    /* light reached by sampling the lights: sum over lights (A / n) sum_j V L_e f cos G w; none where the BSDF
     * has delta lobes alone, whose directions no light sample meets */
    const vint smooth = alive & !bsdf_is_delta(sp);
    vec3 direct = lights_sum(s, sp, wo, smooth, light_samples, ps, rays);
    radiance = v3_add(radiance, v3_select(v3_splat(0.0f, 0.0f, 0.0f), v3_mul(beta, direct), alive));
#if HAS_ENVIRONMENT
    { /* the environment, sampled by its map (environment.cl) or, constant, by the cosine about the normal;
       * the sample's f cos / p_env, weighted against the BSDF's sample of the same direction: x = p_bsdf /
       * p_env */
        vec2 ue = stream_2d(light_samples, bounce, next_stream(ps, bounce, 1), (vint)(0)); /* drawn or not */
        if (ANY(smooth)) { /* the map's sampling and lookups are per lane: none for a packet without use */
#if HAS_ENVIRONMENT_MAP
            vfloat pdf_e;
            vec3 we = sample_environment(s, ue, smooth, &pdf_e);
#else
            vec3 we = cosine_direction(sp.n, ue);
            vfloat pdf_e = v3_dot(sp.n, we) * M_1_PI_F;
#endif
            vfloat cos_e = v3_dot(sp.n, we), pdf_b;
            vint sampled = smooth & (v3_dot(sp.ng, we) > 0.0f) & (cos_e > 0.0f) & (pdf_e > 0.0f);
            vec3 f = bsdf_eval_pdf(sp, wo, we, sampled, &pdf_b);
            vfloat w = power_weight(pdf_b / pdf_e);
            vint open = escapes(s, offset_ray_origin(sp.p, sp.err, sp.ng), we, sampled PASSES(sp.passes));
            *rays += MASK_TO_ONE(sampled);
            if (ANY(open)) {
                vec3 e = v3_mul(v3_mul(beta, f), environment_radiance(s, we, open));
                e = v3_scale(e, w / pdf_e);
                radiance = v3_add(radiance, v3_select(v3_splat(0.0f, 0.0f, 0.0f), e, open));
            }
        }
    }
#endif

    /* the next direction by sampling the BSDF (u2: the direction; the lobe by v.y, the second number of the
     * roulette's pair, which its first alone decides) */
    vec2 u = stream_2d(light_samples, bounce, next_stream(ps, bounce, 1), (vint)(0));
    vec2 v = stream_2d(light_samples, bounce, next_stream(ps, bounce, 1), (vint)(0));
    BSDFSample bs = bsdf_sample(sp, wo, v.y, u, alive);
    const vec3 wi = bs.wi;
    const vint transmit = bs.transmit;
    vfloat cos_s = v3_dot(sp.n, wi), cos_g = v3_dot(sp.ng, wi);
    /* a sample, leaving the surface on the geometric normal's side it chose (the shading normal may disagree) */
    alive &= (bs.pdf > 0.0f) & SELECT(cos_g > 0.0f, cos_g < 0.0f, transmit);
    beta = v3_select(beta, v3_mul(beta, bs.weight), alive);

    /* Russian roulette from vertex rr_depth on, on the throughput onwards: here, after the vertex's light
     * samples and before its ray is traced, as in Mitsuba 3's `path` and pbrt-v4's PathIntegrator, so that a
     * path it ends keeps its vertex's sampled light (the estimate's low-variance part) and costs no ray */
    alive &= russian_roulette(alive & (path->depth >= s->params->rr_depth), v.x, &beta);
    Ray next = {offset_ray_origin(sp.p, sp.err, v3_select(sp.ng, v3_scale(sp.ng, -1.0f), transmit)), wi};
    *rays += MASK_TO_ONE(alive);
    path->r = next;
    path->beta = beta;
    path->radiance = radiance;
#if HAS_NULLS
    const vint passing = sp.bsdf == BSDF_NULL; /* the MIS state stays the vertex's before */
    path->travelled = SELECT((vfloat)(0.0f), path->travelled, passing);
    path->direct &= passing;
#else
    const vint passing = (vint)(0);
#endif
    /* no light sample meets these: light they reach counts whole */
    path->specular = SELECT(bs.delta | transmit, path->specular, passing);
    path->pdf = SELECT(bs.pdf, path->pdf, passing);
#if HAS_ENVIRONMENT
    path->cos_s = SELECT(cos_s, path->cos_s, passing);
#endif
#if LIGHT_SOLID_ANGLE || HAS_SHAPE_EMITTERS
    path->p = v3_select(sp.p, path->p, passing);
#endif
    return alive;
}

/* Radiance along the camera ray r, whose first hit is `hit`, shaded at sp: one pixel sample's path in every
 * lane, vertex after vertex (render.cl's loop does the same, restarting each lane's path where it ends); *rays
 * counts the rays traced per lane after the camera ray. With `cut`, the last vertex max_depth allows traces no
 * ray: what that ray would reach is not counted (max_depth > 1; tests/path_support.py's CUT, for the test that
 * roulette plays after a vertex's light samples). */
inline vec3 trace_path(const Scene *s, TextureStore ts, Ray r, Hit hit, ShadingPoint sp,
                       __global const uint2 *light_samples, PixelSample *ps, vfloat *rays, int cut)
{
    PathState path;
    start_paths(&path, r, (vint)(-1) != 0);
    vint alive = path_hit(s, &path, hit, (vint)(-1) != 0);
    while (ANY(alive)) {
        alive = path_vertex(s, ts, &path, sp, alive, light_samples, ps, rays);
        if (cut && ANY(path.depth + 1 >= s->params->max_depth)) /* the depth is every lane's */
            break;
        hit = closest_hit(s, path.r, (vfloat)(INFINITY));
        alive = path_hit(s, &path, hit, alive);
        sp = shading_point(s, ts, path.r, hit);
    }
    return path.radiance;
}

#endif
