"""Finding, specialising and building the OpenCL program."""
import contextlib
import os
import tempfile
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import pyopencl as cl

from .cpu_target import current_llvm_cpu
from .. import aovs as aov_types
from ..scene import bsdfs
from ..scene.bsdfs import PRINCIPLED_SLOTS, THIN_SLOTS
from ..scene.course_maps import kernel_materials
from .packing import packed_bsdf
from ..scene.model import WRAPPERS, ShapeEmitter


def kernel_dir():
    """kernels/ of a checkout, else the copy installed as the package raytrace.kernels."""
    package = Path(__file__).resolve().parents[1]
    checkout = package.parent / "kernels"
    return checkout if (checkout / "render.cl").is_file() else package / "kernels"


# Shapes from which traversing the BVH is faster than testing every shape, per lane width, from kernel times
# of the loop against the BVH on scene 0 and parts of it (measured in commit 75a3cc2): packets cull so well
# that the BVH wins from one shape; single rays gain only from about 8 shapes.
BVH_CROSSOVER = {1: 8, 4: 1, 8: 1, 16: 1}


@dataclass(frozen=True)
class Features:
    """What a scene needs compiled in. Everything else (counts, sample tables, image size, seeds) is a
    kernel argument, so it never triggers a rebuild."""
    lanes: int = 8
    rectangles: bool = True
    triangles: bool = True
    ellipsoids: bool = True
    colour_maps: bool = True
    normal_maps: bool = True
    height_maps: bool = True
    smooth_normals: bool = False
    bvh: bool = False
    direct_lighting: bool = False  # the scene's shading: radiometric direct lighting
    path_tracing: bool = False     # the scene's shading: global illumination by path tracing (neither: Phong)
    conductors: bool = False       # the path model's smooth conductors (type = "conductor")
    dielectrics: bool = False      # the path model's smooth glass (type = "dielectric")
    rough_conductors: bool = False  # the path model's rough metals (type = "roughconductor")
    environment: bool = False      # the path model's environment emitter
    environment_map: bool = False  # the environment is an image (type = "envmap"), importance-sampled
    thin_dielectrics: bool = False  # the path model's thin glass (type = "thindielectric")
    rough_dielectrics: bool = False  # the path model's rough glass (type = "roughdielectric")
    plastics: bool = False         # the path model's smooth plastic (type = "plastic")
    rough_plastics: bool = False   # the path model's rough plastic (type = "roughplastic")
    principled: bool = False       # the path model's principled BSDF (type = "principled")
    principledthin: bool = False   # the path model's thin principled BSDF (type = "principledthin")
    beckmann: bool = False         # a rough BSDF with distribution = "beckmann" (else GGX alone)
    anisotropic: bool = False      # a rough BSDF with alpha_v other than alpha: shading points carry a tangent
    lookups: bool = False          # textured BSDF parameters (a material's maps: kernels/lookups.cl)
    wrappers: bool = False         # blendbsdf, mask, or a back side other than the front (kernels/wrappers.cl)
    nulls: bool = False            # a mask's null BSDF (type = "null", or a mask)
    perturbed_normals: bool = False  # Mitsuba's normalmap or bumpmap (a material's maps normal, bump)
    principled_lookups: bool = False  # a principled(thin) material's textured weight (maps roughness .. eta)
    shape_emitters: bool = False   # area emitters on shapes (Scene.emitters; kernels/emitters.cl)
    bsdf_sampling: bool = False    # the direct model's BSDF samples (render.bsdf_samples > 0; direct_lighting.cl)
    delta_emitters: bool = False   # point, spot, directional or projector lights (Scene.emitters; emitters.cl)
    instances: bool = False        # instances of shape groups: a two-level BVH (kernels/instances.cl)
    disks: bool = True             # Mitsuba's disk (kernels/disk.cl)
    cylinders: bool = True         # Mitsuba's cylinder (kernels/cylinder.cl)
    thin_lens: bool = False        # the camera is a thin lens (camera.type = "thinlens": kernels/camera.cl)
    orthographic: bool = False     # the camera is orthographic (camera.type = "orthographic")
    rfilter: bool = False          # a reconstruction filter other than the box (kernels/film_filter.cl)
    aovs: int = 0                  # HAS_AOVS: the bits of the AOV types the render stores (raytrace/aovs.py's mask)
    count_visits: bool = False     # a measuring build that counts BVH node visits (bench); never from a scene
    kernels: str = ""              # another kernels/ directory to build from (bench --baseline); never from a scene

    @property
    def textures(self):
        return self.colour_maps or self.normal_maps or self.height_maps or self.lookups

    @classmethod
    def of(cls, scene, lanes):
        materials = kernel_materials(scene)  # (the course's maps, in the path model: course_maps.py)
        used = lambda attribute: any(getattr(m, attribute) >= 0 for m in materials)  # noqa: E731
        shapes = (len(scene.rectangles) + scene.triangle_count + len(scene.ellipsoids) + len(scene.disks)
                  + len(scene.cylinders))
        meshes = [*scene.meshes, *(m for g in scene.groups for m in g.meshes)]
        return cls(lanes, bool(scene.rectangles), scene.triangle_count + scene.group_triangle_count > 0,
                   bool(scene.ellipsoids), used("colour_map"), used("normal_map"), used("height_map"),
                   any(m.smooth for m in meshes), shapes >= BVH_CROSSOVER.get(lanes, 1) or bool(scene.instances),
                   scene.shading == "direct", scene.shading == "path",
                   any(packed_bsdf(m) == "conductor" for m in materials),
                   any(packed_bsdf(m) == "dielectric" for m in materials),
                   any(packed_bsdf(m) == "roughconductor" for m in materials),
                   scene.environment is not None or scene.environment_map is not None,
                   scene.environment_map is not None,
                   disks=bool(scene.disks), cylinders=bool(scene.cylinders),
                   **{name: any(packed_bsdf(m) == bsdf for m in materials)
                      for name, bsdf in (("thin_dielectrics", "thindielectric"),
                                         ("rough_dielectrics", "roughdielectric"), ("plastics", "plastic"),
                                         ("rough_plastics", "roughplastic"), ("principled", "principled"),
                                         ("principledthin", "principledthin"))},
                   beckmann=any(packed_bsdf(m) in bsdfs.ROUGH and m.distribution == "beckmann"
                                for m in materials),
                   anisotropic=any((packed_bsdf(m) in bsdfs.ROUGH and (m.alpha_v not in (None, m.alpha) or dict(
                                   m.maps).get("alpha") != dict(m.maps).get("alpha_v")))
                                   or (m.bsdf in ("principled", "principledthin") and (m.anisotropic != 0 or "anisotropic" in dict(
                                       m.maps))) for m in materials),
                   lookups=any(m.maps for m in materials),
                   wrappers=any(m.bsdf in WRAPPERS or m.back >= 0 or not m.two_sided for m in materials),
                   nulls=any(m.bsdf in ("mask", "null") for m in materials),
                   perturbed_normals=any(slot in ("normal", "bump") for m in materials for slot, _ in m.maps),
                   principled_lookups=any(slot in PRINCIPLED_SLOTS + THIN_SLOTS for m in materials
                                          for slot, _ in m.maps),
                   shape_emitters=any(isinstance(e, ShapeEmitter) for e in scene.emitters),
                   delta_emitters=any(not isinstance(e, ShapeEmitter) for e in scene.emitters),
                   instances=bool(scene.instances),
                   bsdf_sampling=scene.shading == "direct" and scene.bsdf_samples > 0,
                   thin_lens=scene.camera.kind == "thinlens", orthographic=scene.camera.kind == "orthographic",
                   rfilter=scene.rfilter != "box", aovs=aov_types.mask(scene.aovs))

    def options(self):
        flags = {"RECTANGLES": self.rectangles, "TRIANGLES": self.triangles, "ELLIPSOIDS": self.ellipsoids,
                 "DISKS": self.disks, "CYLINDERS": self.cylinders,
                 "COLOUR_MAPS": self.colour_maps, "NORMAL_MAPS": self.normal_maps, "HEIGHT_MAPS": self.height_maps,
                 "SMOOTH_NORMALS": self.smooth_normals, "BVH": self.bvh, "DIRECT_LIGHTING": self.direct_lighting,
                 "PATH_TRACING": self.path_tracing, "CONDUCTORS": self.conductors, "DIELECTRICS": self.dielectrics,
                 "ROUGH_CONDUCTORS": self.rough_conductors, "ENVIRONMENT": self.environment,
                 "ENVIRONMENT_MAP": self.environment_map, "THIN_DIELECTRICS": self.thin_dielectrics,
                 "ROUGH_DIELECTRICS": self.rough_dielectrics, "PLASTICS": self.plastics,
                 "ROUGH_PLASTICS": self.rough_plastics, "PRINCIPLED": self.principled,
                 "PRINCIPLEDTHIN": self.principledthin, "BECKMANN": self.beckmann,
                 "ANISOTROPIC": self.anisotropic,
                 "LOOKUPS": self.lookups, "WRAPPERS": self.wrappers, "NULLS": self.nulls,
                 "PERTURBED_NORMALS": self.perturbed_normals, "PRINCIPLED_LOOKUPS": self.principled_lookups,
                 "SHAPE_EMITTERS": self.shape_emitters, "DELTA_EMITTERS": self.delta_emitters,
                 "INSTANCES": self.instances, "BSDF_SAMPLING": self.bsdf_sampling, "THIN_LENS": self.thin_lens,
                 "ORTHOGRAPHIC": self.orthographic, "RFILTER": self.rfilter}
        return ([f"-DLANES={self.lanes}"] + [f"-DHAS_{name}={int(on)}" for name, on in flags.items()]
                + [f"-DHAS_AOVS={self.aovs}"] + ["-DCOUNT_VISITS=1"] * self.count_visits)


@contextlib.contextmanager
def _compiler_stderr_held():
    """What the OpenCL compiler writes to this process's stderr itself (PoCL's clang prints its diagnostics
    there), held during a build and written out after it, unless a signal cut the build short: a clang
    interrupted mid-read reports an error of its own ("1 error generated.") before the command's one line.
    A signal that arrived during the build is handled (time.sleep(0) lets Python run its handler, which
    raises) before anything held is written."""
    try:
        saved = os.dup(2)
    except OSError:
        yield
        return
    with tempfile.TemporaryFile() as held:
        os.dup2(held.fileno(), 2)

        def restore(replay):
            os.dup2(saved, 2)
            os.close(saved)
            if replay:
                time.sleep(0)  # a signal that came during the build raises here, and nothing is written
                held.seek(0)
                text = held.read()
                if text:
                    os.write(2, text)
        try:
            yield
        except Exception:
            restore(replay=True)
            raise
        except BaseException:  # a signal (outputs.Interrupted, KeyboardInterrupt): the compiler's complaint
            restore(replay=False)  # about being cut short is not the user's business
            raise
        restore(replay=True)


def build(context, source, options=(), kernels=""):
    """Build `source` with kernels/ (or the directory `kernels`) on the include path, keeping each kernel's
    argument names and types for the host to bind by (interface.py); returns (program, seconds)."""
    start = time.perf_counter()
    include = str(kernels or kernel_dir())
    with warnings.catch_warnings():
        if not os.environ.get("PYOPENCL_COMPILER_OUTPUT"):
            # NVIDIA's compiler logs even a clean build; pyopencl makes any log a warning on stderr, which would
            # break the one-line contract of every command. The log stays pyopencl's to show on request.
            warnings.simplefilter("ignore", cl.CompilerWarning)
        with _compiler_stderr_held():
            program = cl.Program(context, source).build(options=[*options, "-cl-kernel-arg-info", "-I", include])
    return program, time.perf_counter() - start


_programs = {}


def render_program(context, features):
    """The renderer's program for these features; build seconds are 0 when it was built before for the same
    target (cpu_target.py)."""
    key = (context, features, tuple(current_llvm_cpu(d) for d in context.devices))
    if key in _programs:
        return _programs[key], 0.0
    _programs[key], seconds = build(context, '#include "render.cl"\n', features.options(), features.kernels)
    return _programs[key], seconds
