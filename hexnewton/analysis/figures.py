"""Figures as the reports ship them: a matplotlib figure written as a PNG of at most 256 colours.

A plot holds few colours (its lines, their anti-aliased edges, the text); a palette of 256 taken by median cut keeps
it as it reads at about a third of the bytes of matplotlib's RGBA file, which is what keeps the studies' figures
small enough to track.
"""

from __future__ import annotations

import io

PALETTE_COLOURS = 256


def save_png(fig, path: str, dpi: int) -> None:
    """Write matplotlib ``fig`` to ``path`` at ``dpi`` as a palette PNG (:data:`PALETTE_COLOURS`, no dithering)."""
    from PIL import Image

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    buf.seek(0)
    with Image.open(buf) as im:
        palette(im).save(path, format="PNG", optimize=True)


def palette(im):
    """``im`` (a PIL image) flattened onto white and reduced to :data:`PALETTE_COLOURS` colours by median cut."""
    from PIL import Image

    rgb = im.convert("RGBA")
    flat = Image.new("RGB", rgb.size, (255, 255, 255))
    flat.paste(rgb, mask=rgb.getchannel("A"))
    return flat.quantize(colors=PALETTE_COLOURS, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE)
