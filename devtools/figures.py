"""The manual's texture figures: `python -m devtools.figures [--out assets/figures] [--quick]`.

Needs matplotlib (an optional extra), imported inside the functions that draw.
"""
import argparse
import dataclasses
import time
from pathlib import Path

import numpy as np

from raytrace import load_file
from raytrace import render
from raytrace.commands.panels import figure_panels, save_figure, show_image
from raytrace.image_file import write_image

SCENES = Path(__file__).resolve().parents[1] / "scenes"
TEXTURED = ("textured_cornell", "grid_floor", "normal_wall", "textured_shapes")
FILTERS = ("nearest", "bilinear", "trilinear", "anisotropic")


def _metadata(scene_name, stats):
    return {"scene": scene_name, "spp": stats.spp, "light_samples": stats.light_samples,
            "sampler": stats.sampler, "seconds": stats.render_seconds, "device": stats.device}


def scenes_figure(out, size=384, single=512, spp=16, light_samples=16, dpi=100):
    """scenes.png: the four textured scenes in a 2 x 2 grid; and each alone as <scene>.png."""
    fig, rows = figure_panels(2, [size, size], size, dpi)
    written = []
    for ax, name in zip([ax for row in rows for ax in row], TEXTURED):
        scene = load_file(SCENES / f"{name}.toml")
        options = dict(spp=spp, light_samples=light_samples, sampler="grid", texture_filter="trilinear",
                       progress=False)
        show_image(ax, render(scene, width=size, height=size, **options)[0], name)
        alone, stats = render(scene, width=single, height=single, **options)
        write_image(out / f"{name}.png", alone, _metadata(name, stats))
        written.append(out / f"{name}.png")
    return [save_figure(fig, out / "scenes.png"), *written]


def without_relief(scene):
    """A copy of `scene` whose materials keep their colour maps but lose normal and height maps."""
    materials = [dataclasses.replace(m, normal_map=-1, height_map=-1, height_scale=0.0) for m in scene.materials]
    return dataclasses.replace(scene, materials=materials)


def normal_height_figure(out, size=512, spp=16, light_samples=16, dpi=100):
    """fig2_normal_height.png: textured_cornell with colour maps only, then with normal and height maps."""
    scene = load_file(SCENES / "textured_cornell.toml")
    fig, rows = figure_panels(2, [size], size, dpi)
    for ax, (s, title) in zip(rows[0], ((without_relief(scene), "colour maps only"),
                                        (scene, "colour + normal + height maps"))):
        image, _ = render(s, width=size, height=size, spp=spp, light_samples=light_samples, sampler="grid",
                          texture_filter="trilinear", progress=False)
        show_image(ax, image, title)
    return save_figure(fig, out / "fig2_normal_height.png")


def filters_figure(out, size=256, reference_spp=1024, dpi=100):
    """fig3_filters.png: grid_floor at 1 spp with each filter beside a supersampled reference (bilinear,
    no MIP-mapping), RMSE against it; below, the far floor zoomed 4 x. Returns {filter: (rmse, seconds)}."""
    import matplotlib.pyplot as plt
    scene = load_file(SCENES / "grid_floor.toml")
    common = dict(width=size, height=size, light_samples=1, progress=False)
    reference, stats = render(scene, spp=reference_spp, sampler="grid", texture_filter="bilinear", **common)
    panels = [(reference, f"reference: {reference_spp} spp,\nbilinear, no MIP-map")]
    table = {"reference": (0.0, stats.render_seconds)}
    for name in FILTERS:
        image, stats = render(scene, spp=1, sampler="center", texture_filter=name, **common)
        rmse = float(np.sqrt(np.mean((image.astype(np.float64) - reference) ** 2)))
        table[name] = (rmse, stats.render_seconds)
        panels.append((image, f"{name}, 1 spp\nRMSE {rmse:.4f}"))
    zoom = 4  # the crop: the far floor just below its far edge (row 0.42 of the image), centred
    r0, h, c0, w = round(0.42 * size), 3 * size // 16, 3 * size // 8, size // 4
    fig, (top, bottom) = figure_panels(len(panels), [size, h * zoom], size, dpi, title_px=44, caption_px=40)
    for k, (image, title) in enumerate(panels):
        show_image(top[k], image, title)
        top[k].add_patch(plt.Rectangle((c0 - 0.5, r0 - 0.5), w, h, fill=False, ec="yellow", lw=0.8))
        show_image(bottom[k], image[r0:r0 + h, c0:c0 + w], f"zoomed {zoom} x")
    fig.text(0.5, 0.005, f"scenes/grid_floor.toml, {size} x {size}, 1 light sample in every panel: the texture "
             "filter is measured, not the shading.\nRMSE over all pixels and channels of the linear image, "
             "against the reference (grid sampler, box filter, no MIP-mapping).", ha="center", va="bottom", fontsize=9)
    save_figure(fig, out / "fig3_filters.png")
    return table


def rmse_markdown(table):
    rows = ["| filter | RMSE | seconds |", "|---|---|---|"]
    rows += [f"| {name} | {'-' if name == 'reference' else f'{rmse:.4f}'} | {seconds:.3f} |"
             for name, (rmse, seconds) in table.items()]
    return "\n".join(rows)


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m devtools.figures", description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=Path, default=Path("assets/figures"), help="output directory")
    parser.add_argument("--quick", action="store_true", help="tiny renders, for a smoke test")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    if args.quick:
        written = scenes_figure(args.out, size=32, single=32, spp=1, light_samples=1)
        written.append(normal_height_figure(args.out, size=32, spp=1, light_samples=1))
        table = filters_figure(args.out, size=32, reference_spp=16)
    else:
        written = scenes_figure(args.out)
        written.append(normal_height_figure(args.out))
        table = filters_figure(args.out)
    written.append(args.out / "fig3_filters.png")
    for path in written:
        print(f"wrote {path}")
    print(rmse_markdown(table))
    print(f"(seconds: kernel time of each render; whole script {time.perf_counter() - start:.1f} s)")
    return table


if __name__ == "__main__":
    main()
