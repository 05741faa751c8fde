"""A contact sheet: several renders side by side, each labelled, for comparing fabrics."""

from __future__ import annotations

import math

import numpy as np

GAP = 8  # pixels between images
LABEL = 18  # pixels of label band under each image


def contact_sheet(images: list[np.ndarray], labels: list[str]):
    """A ``PIL.Image`` (8-bit sRGB) of ``images`` (linear (H, W, 3), same size) on a grid of
    ⌈√n⌉ columns, each with its label underneath."""
    from PIL import Image, ImageDraw

    from ..photo import linear_to_srgb

    n = len(images)
    cols = math.ceil(math.sqrt(n))
    rows = math.ceil(n / cols)
    h, w = images[0].shape[:2]
    sheet = Image.new("RGB", (cols * w + (cols + 1) * GAP, rows * (h + LABEL) + (rows + 1) * GAP), (24, 24, 24))
    draw = ImageDraw.Draw(sheet)
    for k, (image, label) in enumerate(zip(images, labels)):
        r, c = divmod(k, cols)
        x, y = GAP + c * (w + GAP), GAP + r * (h + LABEL + GAP)
        srgb = np.clip(np.round(linear_to_srgb(np.clip(image, 0.0, 1.0)) * 255.0), 0, 255).astype(np.uint8)
        sheet.paste(Image.fromarray(srgb), (x, y))
        draw.text((x + 2, y + h + 3), label, fill=(230, 230, 230))
    return sheet
