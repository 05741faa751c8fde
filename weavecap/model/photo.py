"""``weavecap synth``: a synthetic close-up photo of a fabric, written to an image file — the
forward model's render (:mod:`weavecap.model.render`) under a light rig (§6.4), with the
irregularity noise stored in the params (§6.3, :func:`weavecap.noise.add_noise`)."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from ..io import check_writable, refuse_overwrite
from ..photo import save_image, supported_output
from .scene import View


def synth_photo(params_file: Path, output: Path, view: View, *, light: str = "both", pattern: np.ndarray | None = None,
                noise: bool = True, seed: int = 0, force: bool = False) -> dict:
    """Render the fabric of ``params_file`` (with ``pattern``, (wefts, warps) uint8, in place of
    its own when given) as ``view`` sees it under the rig ``light``, add its noise (``noise``)
    and write it to ``output`` (.png, .exr, .tif); the same inputs and ``seed`` give the same
    image, bit for bit.

    Returns
    -------
    dict
        ``size`` (width, height) in pixels, ``pattern`` (wefts, warps), ``tiles`` (rows,
        columns) and ``seconds`` from the params read to the file written.

    Raises
    ------
    InputError
        An output weavecap cannot write, one that exists without ``force`` (both checked
        before any work, the second again when the image is put in place), or a bad params
        file or pattern.
    """
    from .. import params as wparams
    from .render import render_numpy
    from .scene import build_scene

    supported_output(output)
    check_writable(output, folder=False)
    refuse_overwrite(output, force=force)
    fabric = wparams.load(params_file)
    if pattern is not None:
        fabric = fabric.replace({"pattern": pattern})
    start = time.perf_counter()
    image = render_numpy(build_scene(fabric, view, light=light), seed=seed)
    if noise and fabric.noise:
        from ..noise import add_noise

        pitch_px = image.shape[1] / (view.tiles[1] * fabric.shape[1])  # yarn pitch in the image, px
        image = add_noise(image, fabric.noise, pitch_px=pitch_px, seed=seed)
    save_image(output, image, overwrite=force)
    h, w = image.shape[:2]
    return {"size": (w, h), "pattern": tuple(fabric.shape), "tiles": tuple(view.tiles),
            "seconds": time.perf_counter() - start}
