"""The render kernel's interface is declared once, in kernels/render.cl (and kernels/scene.h's
SCENE_PARAMETERS and TEXTURE_PARAMETERS), and the host binds its values by name from what the device's
compiler reports (raytrace/renderer/interface.py). These tests change that one declaration and check that
the host notices: a renamed, added or retyped argument is a KernelInterfaceError before any launch, and
arguments in another order still render the same image."""

import re
import subprocess
import sys

import numpy as np
import pytest

import raytrace
from raytrace.renderer import interface
from raytrace.renderer.interface import KernelArguments, KernelInterfaceError, declared_type
from raytrace.renderer.program import build, kernel_dir
from raytrace.renderer import device_render
from raytrace.structs import CAMERA, RENDER_PARAMS
from raytrace.commands import child_env

from helpers import ROOT, on_pocl, runnable_lane_widths

OPTIONS = dict(width=16, height=8, spp=1, light_samples=1, sampler="center", light_sampler="center", lanes=1,
               progress=False)


def render_with(monkeypatch, scene, change):
    """Render `scene` through a render kernel whose source is kernels/render.cl changed by `change`."""
    source = change((kernel_dir() / "render.cl").read_text())
    monkeypatch.setattr(device_render, "render_program",
                        lambda context, features: build(context, source, features.options()))
    return raytrace.render(scene, **OPTIONS)[0]


def test_every_argument_is_bound_by_name(monkeypatch, cornell):
    """The host sets every argument the kernel declares, each checked against its declared type."""
    checked = []
    original = KernelArguments.check
    monkeypatch.setattr(KernelArguments, "check", lambda self, name, value: (checked.append(
        (name, self.types[self.index[name]])), original(self, name, value))[1])
    raytrace.render(cornell, **OPTIONS)
    names = [name for name, _ in checked]
    assert set(names) >= {"camera", "params", "lights", "texels", "pixel_samples", "sample0", "row0", "out"}
    assert ("camera", "Camera*") in checked and ("light_samples", "uint2*") in checked and ("row0", "int") in checked


def test_arguments_in_another_order_render_the_same(monkeypatch, cornell):
    expected = raytrace.render(cornell, **OPTIONS)[0]
    swapped = render_with(monkeypatch, cornell, lambda s: s.replace(
        "int sample0, int n_samples, int row0,", "int row0, int n_samples, int sample0,").replace(
        "SCENE_PARAMETERS, TEXTURE_PARAMETERS,", "TEXTURE_PARAMETERS, SCENE_PARAMETERS,"))
    np.testing.assert_array_equal(swapped, expected)


@pytest.mark.parametrize("change, message", [
    (lambda s: re.sub(r"\bn_samples\b", "samples", s), "has no argument 'n_samples'"),
    (lambda s: s.replace("int n_first, int row0,", "int n_first, int row0, int extra,"), "never set: extra"),
    (lambda s: s.replace("__global const uint2 *light_samples", "__global const float2 *light_samples").replace(
        "shade(&scene, ray, hit, sp, light_samples,", "shade(&scene, ray, hit, sp, (__global const uint2 *)light_samples,"),
     "'light_samples' is declared float2"),
    (lambda s: s.replace("int sample0,", "uint sample0,"), "'sample0' is declared uint"),
], ids=["renamed", "added", "pointer retyped", "scalar retyped"])
def test_a_changed_declaration_is_caught(monkeypatch, cornell, change, message):
    with pytest.raises(KernelInterfaceError, match=message):
        render_with(monkeypatch, cornell, change)


def test_declared_types():
    assert declared_type("Camera*") == (CAMERA, 1, True)
    assert declared_type("RenderParams*") == (RENDER_PARAMS, 1, True)
    assert declared_type("uint2*") == (np.dtype(np.uint32), 2, True)
    assert declared_type("int") == (np.dtype(np.int32), 1, False)
    with pytest.raises(KernelInterfaceError, match="no host mirror"):
        declared_type("Unknown*")


def test_host_values_are_checked(cl_env):
    """A table of the wrong struct, a scalar of the wrong width, a vector table of the wrong width."""
    program, _ = build(cl_env[0], '#include "types.h"\n__kernel void k(__constant const Camera *camera, '
                                  'int n, __global const uint2 *table) {}\n')
    args = interface.KernelArguments(program.k)
    args.check("camera", np.zeros((), CAMERA))
    with pytest.raises(KernelInterfaceError, match="'camera' is declared Camera"):
        args.check("camera", np.zeros((), RENDER_PARAMS))
    with pytest.raises(KernelInterfaceError, match="'n' is declared int"):
        args.check("n", np.int64(1))
    with pytest.raises(KernelInterfaceError, match="'table' is declared uint2"):
        args.check("table", np.zeros((4, 3), np.uint32))


LARGE_LAUNCH = r'''
import numpy as np
from raytrace.commands.stability.probe import Probe, planar
SRC = """
#include "path_tracing.cl"
__kernel void sample(int n, __global const float *nrm, __global const float *u, __global float *wi)
{
    ShadingPoint sp;
    sp.p = v3_splat(0.0f, 0.0f, 0.0f);
    sp.err = 0.0f;
    sp.ng = sp.n = IN3(nrm);
    sp.k = v3_splat(1.0f, 1.0f, 1.0f);
    sp.bsdf = (vint)(BSDF_ROUGHDIELECTRIC);
    sp.eta = sp.k_imag = v3_splat(1.5f, 0.0f, 0.0f);
    sp.alpha = sp.alpha_v = 0.3f;
    sp.distribution = (vint)(MICROFACET_GGX);
    sp.backface = (vint)(0);
    vec2 u2 = {IN(u), IN(u)};
    OUT3(wi, bsdf_sample(sp, IN3(nrm), IN(u), u2, (vint)(-1) != 0).wi);
}
"""
n = 1 << 17
out = Probe(16).run(SRC, "sample", n, [planar(np.tile([0, 0, 1.0], (n, 1))), np.linspace(0, 1, n, endpoint=False)],
                    {"wi": 3}, HAS_PATH_TRACING=1, HAS_ROUGH_DIELECTRICS=1, HAS_RECTANGLES=1)
assert np.all(np.isfinite(out["wi"])), "not finite"
print("ran", out["wi"].shape[1])
'''


@on_pocl
def test_a_large_probe_launch_runs():
    """The test kernels' harness (raytrace/commands/stability/probe.py) launches the vector kernels on a CPU in
    groups of one work-item, as the renderer does: with PoCL's own choice of group, a launch of 8192 work-items
    of a kernel that samples a BSDF at 16 lanes ended the process with a segmentation fault (seen: exit status
    -11 before the change, in a child process so that the crash cannot take the test session with it)."""
    if 16 not in runnable_lane_widths():
        pytest.skip("this machine's target does not run 16 lanes")
    done = subprocess.run([sys.executable, "-c", LARGE_LAUNCH], capture_output=True, text=True, cwd=ROOT,
                          env=child_env(None), timeout=600)
    assert done.returncode == 0 and done.stdout.strip() == "ran 131072", (done.returncode, done.stderr[-2000:])
