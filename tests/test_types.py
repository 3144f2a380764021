"""Every struct in kernels/types.h against its numpy mirror in raytrace/structs.py, and every constant of
kernels/types.h and kernels/limits.h against its mirror: as this device's compiler lays them out and
defines them."""
import pyopencl as cl
import pytest

from raytrace import structs
from raytrace.renderer.program import build
from helpers import run_int_kernel, values_kernel


def test_struct_layout_matches_device(cl_env):
    checks, host = [], []
    for struct, dtype in structs.STRUCTS.items():
        checks.append(f"sizeof({struct})")
        checks += [f"__builtin_offsetof({struct}, {field})" for field in dtype.names]
        host.append(dtype.itemsize)
        host += [dtype.fields[name][1] for name in dtype.names]
    assert run_int_kernel(cl_env, values_kernel(checks), len(checks)) == host


def padding_problems(cl_env, declarations, fields):
    """What the device's compiler lays out with padding in the structs of `declarations` ({struct: field
    names}): a field not 4-byte aligned or not a multiple of 4 bytes long, or a struct larger than its
    fields (hidden padding, which a packed numpy mirror would not have)."""
    checks = []
    for struct, names in fields.items():
        checks.append(f"sizeof({struct})")
        for name in names:
            checks += [f"__builtin_offsetof({struct}, {name})", f"sizeof((({struct} *)0)->{name})"]
    values = iter(run_int_kernel(cl_env, declarations + values_kernel(checks), len(checks)))
    problems = []
    for struct, names in fields.items():
        size, total = next(values), 0
        for name in names:
            offset, length = next(values), next(values)
            total += length
            if offset % 4 or length % 4:
                problems.append(f"{struct}.{name}: offset {offset}, {length} bytes")
        if total != size:
            problems.append(f"{struct}: {size} bytes for {total} bytes of fields")
    return problems


def test_no_struct_has_hidden_padding(cl_env):
    """Every field of every struct the kernel reads is 4-byte aligned and a whole number of 4-byte words,
    and the fields fill their struct, as the device lays them out: so a packed numpy mirror matches on every
    OpenCL device, whatever its alignment rules."""
    assert padding_problems(cl_env, "", {s: d.names for s, d in structs.STRUCTS.items()}) == []


def test_padding_is_found(cl_env):
    """The check above can fail: a float3 (16-byte aligned, 16 bytes) before a float, and a char before an
    int, are each reported."""
    declarations = ("typedef struct { float x; float3 v; } Vector;\n"
                    "typedef struct { char c; int i; } Holed;\n")
    problems = padding_problems(cl_env, declarations, {"Vector": ["x", "v"], "Holed": ["c", "i"]})
    assert any(p.startswith("Vector:") for p in problems)
    assert "Holed.c: offset 0, 1 bytes" in problems and any(p.startswith("Holed:") for p in problems)


def test_constants_match_device(cl_env):
    """The WRAP_*, FILTER_*, RFILTER_*, RANDOMIZE_*, BSDF_*, SHAPE_*, EMITTER_*, PRIM_KIND*, MAP_*, LOOKUP_* and TEXELS_* macros of kernels/types.h and the limits of
    kernels/limits.h against their mirrors in raytrace/structs.py."""
    names = {f"WRAP_{k.upper()}": v for k, v in structs.WRAP_MODES.items()}
    names |= {f"FILTER_{k.upper()}": v for k, v in structs.FILTERS.items()}
    names |= {f"RFILTER_{k.upper()}": v for k, v in structs.RFILTERS.items()}
    names |= {f"RANDOMIZE_{k.upper()}": v for k, v in structs.RANDOMIZE.items()}
    names |= {f"BSDF_{k.upper()}": v for k, v in structs.BSDFS.items()}
    names |= {f"MICROFACET_{k.upper()}": v for k, v in structs.MICROFACETS.items()}
    names |= {f"SHAPE_{k.upper()}": v for k, v in structs.SHAPES.items()}
    names |= {f"EMITTER_{k.upper()}": v for k, v in structs.EMITTER_KINDS.items()}
    names |= {"PRIM_KIND_BITS": structs.PRIM_KIND_BITS, "PRIM_KINDS": structs.PRIM_KINDS}
    names |= {f"MAP_{k.upper()}": v for k, v in structs.MAP_SLOTS.items()}
    names |= {f"LOOKUP_{k.upper()}": v for k, v in structs.LOOKUPS.items()}
    names |= {"BSDF_BLEND": structs.BSDF_BLEND, "MAPS": structs.MAPS, "WRAPPER_DEPTH": structs.WRAPPER_DEPTH}
    names |= {"TEXELS_SRGB8": structs.TEXELS_SRGB8, "TEXELS_UNORM8": structs.TEXELS_UNORM8,
              "TEXELS_FLOAT": structs.TEXELS_FLOAT, "TEXELS_QUAD8": structs.TEXELS_QUAD8,
              "TEXELS_QUADF": structs.TEXELS_QUADF, "TEXELS_QUAD16": structs.TEXELS_QUAD16}
    names |= {"BVH_STACK": structs.BVH_STACK, "CULLED_RECTANGLES": structs.CULLED_RECTANGLES,
              "ROUGH_TRANSMITTANCE_RES": structs.ROUGH_TRANSMITTANCE_RES,
              "RFILTER_NODES": structs.RFILTER_NODES}
    names |= {"PRINCIPLED_PARAMETERS": structs.PRINCIPLED_PARAMETERS}
    names |= {f"PRINCIPLED_{k.upper()}": i for i, k in enumerate(structs.PRINCIPLED)}
    assert run_int_kernel(cl_env, values_kernel(names), len(names)) == list(names.values())


def test_quad_encodings_match_device(cl_env):
    """types.h's TEXELS_ARE_QUADS against structs.QUAD_TEXELS, for every encoding the host knows and one
    beyond."""
    encodings = range(max(structs.TEXEL_WORDS) + 2)
    found = run_int_kernel(cl_env, values_kernel([f"TEXELS_ARE_QUADS({e})" for e in encodings]), len(encodings))
    assert [e for e in encodings if found[e]] == sorted(structs.QUAD_TEXELS)


def test_lane_widths_match_device(cl_env):
    """limits.h's LANE_WIDTH_ACCEPTED against structs.LANE_WIDTHS, for every width up to 64."""
    accepted = run_int_kernel(cl_env, values_kernel([f"LANE_WIDTH_ACCEPTED({n})" for n in range(65)]), 65)
    assert [n for n in range(65) if accepted[n]] == list(structs.LANE_WIDTHS)


@pytest.mark.parametrize("lanes", [0, 2, 3, 32])
def test_other_lane_widths_do_not_build(cl_env, lanes):
    with pytest.raises(cl.RuntimeError, match="LANES must be"):
        build(cl_env[0], '#include "lanes.h"\n__kernel void k(void) {}\n', [f"-DLANES={lanes}"])
