"""How the renderer's cost grows with the triangle count: `python -m raytrace bench --scaling`.

A procedural mesh (a displaced torus, raytrace/scene/meshgen.py) of 10^2 ... 10^6 (10^7 with --max-triangles)
triangles stands in scene 0's room instead of the tetrahedron and the ellipsoid; each is rendered at 256 x 256
with 4 pixel samples x 4 light samples (fixed: the render options of `bench` do not apply). With a BVH the
time per ray should grow like log N; a loop over every shape grows like N. Writes scaling.csv and scaling.png
(log-log: seconds per ray and BVH build seconds against the number of triangles); each row also has the BVH
nodes and primitives tested per camera and per shadow ray (visits.py, counted in this process), and
visits.png maps the node visits pixel by pixel for the smallest and the largest mesh. Each row also has the
cost of a scattered ray: the room rendered in the path model to depth 2 (camera rays, the light samples at
their hits, and one cosine-distributed bounce ray from each) against the direct model (the same without the
bounce), the difference in seconds over the difference in rays (bounce_seconds_per_ray). With an anchor
(`python -m benchmarks.embree_anchor`, a developer's rig outside the package) each row also has Embree's ns per
ray on the same geometry and kinds of rays, on one core, as measured and net of what its Python binding costs
a ray: beside ours, its growth is the anchor."""
import csv
import dataclasses
import time
from pathlib import Path

import numpy as np

from ..renderer import bvh
from ..scene import meshgen
from ..render import render
from ..outputs import Outputs, scene_inputs
from ..scene import Material, MeshShape, load_file
from ..renderer.geometry import primitive_boxes, triangle_soup
from .bench import in_turns, paired_ratios
from .visits import PER_RAY, node_visits, plot_maps

OPTIONS = dict(width=256, height=256, spp=4, light_samples=4, progress=False)
COLUMNS = ["triangles", "build_seconds", "render_seconds", "rays", "seconds_per_ray", "mrays_per_s",
           "nominal_mrays_per_s", *PER_RAY, "bounce_rays", "bounce_seconds_per_ray"]


# Each row's renders are repeated for at least this many seconds (and at least 3 times), and the fastest is
# kept: the smallest meshes render so quickly that the best of three of those moved a lot between runs, and
# the growth from 10^3 to 10^6 with it (measured in commit f1bffac).
TIMING_SECONDS = 1.0

# Turns of bench --scaling's paired growth (paired_growth): one render of 10^3 and one of the largest mesh each.
PAIRED_TURNS = 7

GOLD = Material("scaling gold", np.array([1.0, 0.8, 0.4]), shininess=40.0)


def mesh_room(scene, triangles):
    """The scene's lights and rectangles (scene 0's room) with a smooth torus of about `triangles` triangles
    instead of its other shapes, in a material of its own."""
    torus = meshgen.torus(triangles)
    torus.vertices = torus.vertices * 0.45 + [0.0, 0.1, 0.75]
    mesh = MeshShape(torus, len(scene.materials), smooth=True)
    return dataclasses.replace(scene, triangles=[], ellipsoids=[], meshes=[mesh], materials=[*scene.materials, GOLD])


def measure(scene, scheduler=None):
    """One row of the table: BVH build seconds (alone, as the render does it), the fastest of the renders
    repeated for TIMING_SECONDS and the BVH nodes and primitives tested per ray, after the counting render's
    whole result (visits.py)."""
    lo, hi, _ = primitive_boxes(scene, triangle_soup(scene))
    start = time.perf_counter()
    bvh.build(lo, hi)
    build_seconds = time.perf_counter() - start
    options = dict(OPTIONS, scheduler=scheduler)
    render(scene, **options)  # the kernel's build and first launch: not timed
    stats = min(_renders(scene, options), key=lambda s: s.render_seconds)
    nominal = OPTIONS["width"] * OPTIONS["height"] * OPTIONS["spp"] * (1 + OPTIONS["light_samples"])
    visits = node_visits(scene, **OPTIONS)
    bounce_rays, bounce_seconds = bounce_cost(scene, options)
    return visits, {"triangles": scene.triangle_count, "build_seconds": build_seconds,
            "render_seconds": stats.render_seconds, "rays": stats.rays,
            "seconds_per_ray": stats.render_seconds / stats.rays, "mrays_per_s": stats.mrays_per_s,
            "nominal_mrays_per_s": nominal / stats.render_seconds / 1e6,
            **{key: visits[key] for key in PER_RAY},
            "bounce_rays": bounce_rays, "bounce_seconds_per_ray": bounce_seconds / bounce_rays}


def bounce_cost(scene, options):
    """(bounce rays, their seconds): the room without its ambient term rendered in the path model to depth 2
    against the direct model, each the fastest of renders repeated for TIMING_SECONDS. The path model's renders
    trace what the direct model's do (camera rays, then light_samples shadow rays from each hit) and from each
    hit one bounce ray with the diffuse BSDF's density cos / pi, and weigh the light samples for MIS: the
    difference is the bounce rays' traversal, their sampling and those weights, so it errs against us."""
    room = dataclasses.replace(scene, ambient=np.zeros(3))
    direct, path = (min(_renders(room, dict(options, **model)), key=lambda s: s.render_seconds)
                    for model in ({"shading": "direct"}, {"shading": "path", "max_depth": 2}))
    return path.rays - direct.rays, path.render_seconds - direct.render_seconds


def _renders(scene, options):
    """The stats of renders repeated for TIMING_SECONDS, at least 3."""
    runs, start = [], time.perf_counter()
    while len(runs) < 3 or time.perf_counter() - start < TIMING_SECONDS:
        runs.append(render(scene, **options)[1])
    return runs


def paired_growth(low, high, scheduler=None, turns=PAIRED_TURNS):
    """The per-ray cost of the scene `high` against `low` as the median over turns of one render of each, taken
    seconds apart, in alternating order (bench's in_turns and paired_ratios; a scene's ray count is the same in
    every render), so that a slow spell of the machine falls on both; the rows' growth divides two fastest
    renders that may come from different minutes. Neither is steady on a shared machine: runs an hour apart
    gave growths far apart, by the rows and paired alike (measured in commit 8b112a1), as a neighbour's load
    slows the 10^6 mesh's memory-bound renders more than 10^3's. Both scenes' tables stay packed
    (renderer/scene_tables.py keeps every live scene's), so a turn costs two renders."""
    options = {key: value for key, value in OPTIONS.items() if key != "progress"}  # in_turns sets it
    best, seconds = in_turns([low, high], turns, dict(options, scheduler=scheduler), alternate=True)
    return paired_ratios(seconds)[1] * best[0].rays / best[1].rays


FILES = ("scaling.csv", "scaling.png", "visits.png")


def scaling(scene_path, out_dir, max_triangles=10**6, out=None, anchor=None, scheduler=None):
    """The table's rows; scaling.csv, scaling.png and visits.png in `out_dir`, written all or none (through
    raytrace.outputs.Outputs: the directory made if need be, removed again with its files when the run fails,
    errors naming --scaling). `anchor`, when given, measures another tracer on each row's room (a function of
    the room returning ns_per_ray and net_ns_per_ray, as benchmarks/embree_anchor.py's measure): it runs first
    in each row, so that a missing dependency stops the run before any render."""
    scene = load_file(scene_path)
    with Outputs(inputs=scene_inputs(scene)) as outputs:
        outputs.make_directory("--scaling", out_dir)
        files = {name: outputs.reserve("--scaling", Path(out_dir) / name, given=out_dir) for name in FILES}
        rows = _measure_rows(scene, files, outputs, max_triangles, out, anchor, scheduler)
        outputs.commit()
    return rows


def _measure_rows(scene, files, outputs, max_triangles, out, anchor, scheduler):
    embree = anchor is not None
    rows, maps, rooms = [], [], {}
    counts = [10**k for k in range(2, 8) if 10**k <= max_triangles]
    for n in counts:
        room = rooms[n] = mesh_room(scene, n)
        measured = anchor(room) if embree else None
        visits, row = measure(room, scheduler)
        rows.append(row)
        if n not in (10**3, counts[-1]):
            del rooms[n]  # its packed tables go with it
        if n in (counts[0], counts[-1]):
            maps.append((f"{room.triangle_count:,} triangles", visits))
        if measured:
            rows[-1]["embree_ns_per_ray"] = measured["ns_per_ray"]
            rows[-1]["embree_net_ns_per_ray"] = measured["net_ns_per_ray"]
            rows[-1]["embree_bounce_ns_per_ray"] = measured["bounce_ns_per_ray"]
            rows[-1]["embree_bounce_net_ns_per_ray"] = measured["bounce_net_ns_per_ray"]
        if out:
            r = rows[-1]
            print(f"{r['triangles']:>9d} triangles: BVH {r['build_seconds']:7.2f} s, render {r['render_seconds']:6.3f} s, "
                  f"{r['seconds_per_ray'] * 1e9:7.1f} ns per ray, {r['mrays_per_s']:6.2f} Mrays/s, BVH nodes and "
                  f"primitives per camera ray {r['visits_per_camera_ray']:.2f} and {r['primitives_per_camera_ray']:.2f}, "
                  f"per shadow ray {r['visits_per_shadow_ray']:.2f} and {r['primitives_per_shadow_ray']:.2f}; "
                  f"scattered rays {r['bounce_seconds_per_ray'] * 1e9:.1f} ns per ray"
                  + (f"; Embree {measured['ns_per_ray']:7.1f} ns per ray on 1 core "
                     f"({measured['ns_per_ray_all_cores']:.1f} ideal on {measured['cores']}), "
                     f"{measured['net_ns_per_ray']:.1f} net of its binding's {measured['binding_ns_per_ray']:.1f}, "
                     f"scattered rays {measured['bounce_ns_per_ray']:.1f} ({measured['bounce_net_ns_per_ray']:.1f} "
                     f"net)" if measured else ""),
                  file=out, flush=True)
    if out and 10**3 in counts[:-1]:
        print(growth(rows, counts, rooms, embree, scheduler), file=out, flush=True)
    with outputs.writing(files["scaling.csv"]) as path, open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, COLUMNS + ["embree_ns_per_ray", "embree_net_ns_per_ray", "embree_bounce_ns_per_ray",
                                              "embree_bounce_net_ns_per_ray"] * embree)
        writer.writeheader()
        writer.writerows(rows)
    with outputs.writing(files["scaling.png"]) as path:
        plot(rows, path)
    with outputs.writing(files["visits.png"]) as path:
        plot_maps(maps, path, OPTIONS["spp"])
    return rows


def growth(rows, counts, rooms, embree, scheduler=None):
    """The line on how the per-ray cost grows from 10^3 triangles to the largest mesh: between the rows' fastest
    renders, paired (paired_growth), and Embree's where it was measured, as measured and net of the binding's own
    cost a ray (embree_anchor.unmet_scene)."""
    low, high = rows[counts.index(10**3)], rows[-1]
    ours = high["seconds_per_ray"] / low["seconds_per_ray"]
    paired = paired_growth(rooms[10**3], rooms[counts[-1]], scheduler)
    theirs = "".join(f", Embree x{high[key] / low[key]:.2f}{what}" for key, what in
                     (("embree_ns_per_ray", ""), ("embree_net_ns_per_ray", " (net of its binding)")) if embree)
    return (f"per-ray cost from 10^3 to 10^{len(counts) + 1} triangles: ours x{ours:.2f} (the rows' fastest renders), "
            f"x{paired:.2f} (paired: the median of {PAIRED_TURNS} turns of one render each){theirs}")


def plot(rows, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    n = np.array([r["triangles"] for r in rows], float)
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.loglog(n, [r["seconds_per_ray"] * 1e9 for r in rows], "o-", label="render: ns per ray")
    ax.loglog(n, [r["bounce_seconds_per_ray"] * 1e9 for r in rows], "D-", label="render: ns per scattered ray")
    ax.loglog(n, [r["build_seconds"] * 1e3 for r in rows], "s-", label="BVH build: ms")
    if "embree_ns_per_ray" in rows[0]:
        ax.loglog(n, [r["embree_ns_per_ray"] for r in rows], "^--", label="Embree, 1 core: ns per ray")
        ax.loglog(n, [r["embree_net_ns_per_ray"] for r in rows], "v:", label="Embree net of its binding")
        ax.loglog(n, [r["embree_bounce_net_ns_per_ray"] for r in rows], "d:",
                  label="Embree net, ns per scattered ray")
    ax.set_xlabel("triangles")
    ax.set_title("Cost against scene size (256x256, 4 spp x 4 light samples)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
