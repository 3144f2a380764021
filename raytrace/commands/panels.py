"""Figures of images shown pixel for pixel (matplotlib, the `analysis` extra, imported only when drawing):
converge's montage and the manual's figures (devtools/figures.py) lay out their panels with these."""
from ..image_file import encode_8bit


def figure_panels(cols, heights, width, dpi, title_px=36, gap=10, caption_px=0):
    """A figure whose axes are exactly `width` x heights[i] pixels at `dpi`, so images show 1:1 (or at an
    integer zoom) and no texel is dropped or smeared by resampling; returns (figure, rows of axes)."""
    import matplotlib.pyplot as plt
    fig_w, fig_h = cols * width + (cols + 1) * gap, sum(heights) + len(heights) * title_px + gap + caption_px
    fig = plt.figure(figsize=(fig_w / dpi, fig_h / dpi), dpi=dpi)
    rows, top = [], fig_h
    for h in heights:
        top -= title_px + h
        rows.append([fig.add_axes(((gap + c * (width + gap)) / fig_w, top / fig_h, width / fig_w, h / fig_h))
                     for c in range(cols)])
    return fig, rows


def show_image(ax, image, title):
    """One panel: the image as the project's 8-bit PNGs encode it, pixels as squares, no ticks."""
    ax.imshow(encode_8bit(image), interpolation="nearest", aspect="auto")
    ax.set_title(title, fontsize=10)
    ax.set_xticks([])
    ax.set_yticks([])


def save_figure(fig, path):
    fig.savefig(path, dpi=fig.dpi, bbox_inches="tight", pad_inches=0.04)
    import matplotlib.pyplot as plt
    plt.close(fig)
    return path
