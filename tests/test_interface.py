"""The render kernel's interface is declared once, in kernels/render.cl (and kernels/scene.h's
SCENE_PARAMETERS and TEXTURE_PARAMETERS), and the host binds its values by name from what the device's
compiler reports (raytrace/renderer/interface.py). These tests change that one declaration and check that
the host notices: a renamed, added or retyped argument is a KernelInterfaceError before any launch, and
arguments in another order still render the same image."""

import re

import numpy as np
import pytest

import raytrace
from raytrace.renderer import interface
from raytrace.renderer.interface import KernelArguments, KernelInterfaceError, declared_type
from raytrace.renderer.program import build, kernel_dir
from raytrace.renderer import device_render
from raytrace.structs import CAMERA, RENDER_PARAMS

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
    (lambda s: s.replace("int row0,", "int row0, int extra,"), "never set: extra"),
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
