"""What the BSDF tests share (tests/test_bsdf_*.py): a test kernel that runs kernels/bsdf.cl's interface on a
shading point per lane, and the host side that fills that point from a table of types.h's Material and runs
the kernel through the `harness` fixture's Probe.

A test describes its materials as the renderer packs them, a raytrace.structs.MATERIAL table: made by
raytrace/renderer/packing.py's material_structs from model.Materials (the plastics' coat terms and the rough
plastic's transmittance table included), or field by field with material_table (values the scene model
would not pass as they are: a rough BSDF below packing.py's SMOOTH_ALPHA, per-lane roughness). Each lane takes
an entry of it (`which`); run() hands the kernel that entry's values lane by lane, as material.cl's
shading_point gathers them, and returns what the test asks for (OUTPUTS), lanes first. Beside it, the random
shading points and viewers the tests draw (facing)."""
import numpy as np

from raytrace import structs
from raytrace.commands.stability.probe import planar

# Each lane's shading point: the normal nrm (n and ng), the tangent tan (the anisotropic build's t), backface,
# and the lane's material values (bsdf, k the colour, eta, k_imag, alpha, alpha_v, distribution, specular,
# nonlinear, r_int, weight_s; material, its index into the table materials, for the rough plastic's
# transmittance and the principled BSDF's values), each read where the build has the field. It computes the
# outputs a test wants (OUTPUTS, in that order): output j goes to out + slot[j] n, its components one after
# another, and slot[j] = -1 is one not wanted and not computed.
KERNEL = """
#include "bsdf.cl"
enum { F, PDF, F_SWAPPED, DELTA_BSDF, S_WI, S_WEIGHT, S_PDF, S_DELTA, S_TRANSMIT, S_F, S_EVAL_PDF };
#define WANT(j) (slot[j] >= 0)
#define PUT(j, v) if (WANT(j)) OUT(out + slot[j] * n, (v))
#define PUT3(j, v) if (WANT(j)) OUT3(out + slot[j] * n, (v))
#define FLAG(mask) SELECT((vfloat)(0.0f), (vfloat)(1.0f), (mask) != 0)

inline ShadingPoint lane_point(int n, __global const float *nrm, __global const float *tan,
                               __global const int *backface, __global const int *bsdf, __global const float *k,
                               __global const float *eta, __global const float *k_imag,
                               __global const float *alpha, __global const float *alpha_v,
                               __global const int *distribution, __global const float *specular,
                               __global const int *nonlinear, __global const float *r_int,
                               __global const float *weight_s, __global const int *material,
                               __global const Material *materials)
{
    ShadingPoint sp;
    sp.p = v3_splat(0.0f, 0.0f, 0.0f);
    sp.err = 0.0f;
    sp.ng = sp.n = IN3(nrm);
    sp.k = IN3(k);
    sp.shininess = 1.0f;
#if HAS_BSDF_PARAMETERS
    sp.bsdf = VLOAD_INT(bsdf + I * LANES);
    sp.eta = IN3(eta);
    sp.k_imag = IN3(k_imag);
    sp.alpha = IN(alpha);
#endif
#if HAS_MICROFACETS
    sp.alpha_v = IN(alpha_v);
    sp.distribution = VLOAD_INT(distribution + I * LANES);
#endif
#if HAS_ANISOTROPIC
    sp.t = IN3(tan);
#endif
#if HAS_COATS
    sp.specular = IN3(specular);
    sp.nonlinear = VLOAD_INT(nonlinear + I * LANES);
    sp.internal_reflectance = IN(r_int);
    sp.specular_weight = IN(weight_s);
#endif
#if HAS_ROUGH_PLASTICS
    sp.material = VLOAD_INT(material + I * LANES);
    sp.materials = materials;
#endif
#if HAS_BACKFACES
    sp.backface = VLOAD_INT(backface + I * LANES);
#endif
#if HAS_PRINCIPLED_VALUES /* each lane's material's values, gathered from the table as material.cl does */
    for (int j = 0; j < PRINCIPLED_PARAMETERS; ++j) {
        float v[LANES];
        for (int i = 0; i < LANES; ++i)
            v[i] = materials[material[I * LANES + i]].principled[j];
        sp.principled[j] = VLOAD(v);
    }
#endif
    return sp;
}

__kernel void bsdf_lanes(int n, __global const float *nrm, __global const float *tan, __global const int *backface,
                         __global const int *bsdf, __global const float *k, __global const float *eta,
                         __global const float *k_imag, __global const float *alpha, __global const float *alpha_v,
                         __global const int *distribution, __global const float *specular,
                         __global const int *nonlinear, __global const float *r_int,
                         __global const float *weight_s, __global const int *material,
                         __global const Material *materials, __global const float *wo_,
                         __global const float *wi_, __global const float *u, __global const int *slot,
                         __global float *out)
{
    ShadingPoint sp = lane_point(n, nrm, tan, backface, bsdf, k, eta, k_imag, alpha, alpha_v, distribution,
                                 specular, nonlinear, r_int, weight_s, material, materials);
    const vint all = (vint)(-1) != 0;
    const vec3 wo = IN3(wo_);
    vfloat p;
    if (WANT(F) || WANT(PDF)) {
        vec3 value = bsdf_eval_pdf(sp, wo, IN3(wi_), all, &p);
        PUT3(F, value);
        PUT(PDF, p);
    }
    PUT3(F_SWAPPED, bsdf_eval(sp, IN3(wi_), wo, all));
    PUT(DELTA_BSDF, FLAG(bsdf_is_delta(sp)));
    int sample = 0;
    for (int j = S_WI; j <= S_EVAL_PDF; ++j)
        sample |= WANT(j);
    if (sample) {
        vec2 u2 = {IN(u + n), IN(u + 2 * n)};
        BSDFSample bs = bsdf_sample(sp, wo, IN(u), u2, all);
        PUT3(S_WI, bs.wi);
        PUT3(S_WEIGHT, bs.weight);
        PUT(S_PDF, bs.pdf);
        PUT(S_DELTA, FLAG(bs.delta));
        PUT(S_TRANSMIT, FLAG(bs.transmit));
        if (WANT(S_F) || WANT(S_EVAL_PDF)) {
            vec3 value = bsdf_eval_pdf(sp, wo, bs.wi, all, &p);
            PUT3(S_F, value);
            PUT(S_EVAL_PDF, p);
        }
    }
}
"""

# The kernel's outputs and their components, in its order: f and pdf, bsdf_eval_pdf at (wo, wi); f_swapped,
# bsdf_eval at (wi, wo); delta_bsdf, 1 where bsdf_is_delta; s_wi, s_weight, s_pdf, s_delta and s_transmit,
# bsdf_sample's BSDFSample (the flags as 1 and 0); s_f and s_eval_pdf, bsdf_eval_pdf at (wo, s_wi).
OUTPUTS = {"f": 3, "pdf": 1, "f_swapped": 3, "delta_bsdf": 1, "s_wi": 3, "s_weight": 3, "s_pdf": 1, "s_delta": 1,
           "s_transmit": 1, "s_f": 3, "s_eval_pdf": 1}


def unit(v):
    """The unit vectors along v's rows (or along v)."""
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def facing(rng, m):
    """m random unit normals and m random unit directions, each on its normal's side (uniform over the sphere,
    then turned to that side): shading points and the viewers that see them."""
    normal, wo = unit(rng.normal(size=(m, 3))), unit(rng.normal(size=(m, 3)))
    return normal, wo * np.sign(np.sum(wo * normal, axis=1))[:, None]


def material_table(count=1, **fields):
    """`count` entries of types.h's Material (raytrace.structs.MATERIAL), colour 1 and the rest 0 but the given
    fields, each one value for every entry or one per entry (bsdf and distribution by name: "roughconductor",
    "ggx"): the values as the kernel reads them, without packing.py's checks and choices."""
    table = np.zeros(count, structs.MATERIAL)
    table["colour"] = 1.0
    names = {"bsdf": structs.BSDFS, "distribution": structs.MICROFACETS}
    for key, value in fields.items():
        if key in names:
            value = np.vectorize(names[key].__getitem__, otypes=[np.int32])(value)
        table[key] = value
    return table


def run(harness, table, nrm, wo, wi=None, u=None, outputs=tuple(OUTPUTS), which=None, tangent=None,
        backface=None, **build):
    """The kernel's `outputs` (names of OUTPUTS) on len(wo) lanes, in one launch of the harness's Probe, built
    with the options `build` (HAS_*): lane i's shading point has normal nrm[i], the material table[which[i]]
    (default: entry i modulo the table's length, so one entry for every lane, or one per lane), tangent
    tangent[i] (default 0: read by the anisotropic build only) and backface[i] (default 0); it is seen from
    wo[i] and evaluated towards wi[i] (default wo), and sampled with u[i] = (u1, u2) (default 0). Returns
    {name: float64 array, (lanes,) or (lanes, 3)}."""
    m = len(wo)
    assert set(outputs) <= set(OUTPUTS), f"no such output: {sorted(set(outputs) - set(OUTPUTS))}"
    assert all(len(a) == m for a in (nrm, wi, u, tangent, backface, which) if a is not None), "one row per lane"
    which = np.arange(m) % len(table) if which is None else np.asarray(which)
    assert which.min() >= 0 and which.max() < len(table), "which names an entry of the table"
    field = lambda key: table[key][which]  # noqa: E731
    slot, at, total = np.full(len(OUTPUTS), -1, np.int32), {}, 0  # each output's first row of out
    for name in outputs:
        slot[list(OUTPUTS).index(name)] = at[name] = total
        total += OUTPUTS[name]
    zeros = np.zeros((m, 3))
    args = [planar(nrm), planar(zeros if tangent is None else tangent),
            np.zeros(m, np.int32) if backface is None else np.asarray(backface, np.int32), field("bsdf"),
            planar(field("colour")), planar(field("eta")), planar(field("k")), field("alpha"), field("alpha_v"),
            field("distribution"), planar(field("specular")), field("nonlinear"), field("internal_reflectance"),
            field("specular_weight"), which.astype(np.int32), table, planar(wo), planar(wo if wi is None else wi),
            planar(zeros if u is None else u), slot]
    out = harness.run(KERNEL, "bsdf_lanes", m, args, {"out": total}, **build)["out"].reshape(total, m)
    # a BSDF's value, density and sample are finite for every direction, parameter and sample point, what a
    # render's sums rely on, checked on every lane of every BSDF test; a sample's direction where there is no
    # sample (s_pdf 0: path_tracing.cl ends the path there) may be anything. A weight made inf on 1 lane in 1000
    # of plastic.cl's samples fails tests/test_bsdf_plastic.py here (tried).
    ok = np.isfinite(out)
    if "s_wi" in outputs:
        ok[at["s_wi"]:at["s_wi"] + 3] |= out[at["s_pdf"]] == 0 if "s_pdf" in outputs else True
    assert ok.all(), {name: int((~ok[at[name]:at[name] + OUTPUTS[name]]).sum()) for name in outputs}
    return {name: out[at[name]:at[name] + 3].T if OUTPUTS[name] == 3 else out[at[name]] for name in outputs}
