"""The woven neural renderer (Chen et al. 2024, *Real-time Neural Woven Fabric Rendering*).

One small network for every captured fabric: an encoder turns a fabric's baked surface maps and
non-colour parameters into a latent once; a decoder, compiled into the render kernel, turns a
pixel's footprint and the light and view directions into the footprint-filtered surface BSDF,
split into colour-free channels the colours multiply (so colours change without re-encoding).

- :mod:`.terms` splits :func:`weavecap.render.bsdf.eval_surface` into those channels (exact);
- :mod:`.footprint` filters periodic maps over boxes (summed-area tables) and makes the
  prefiltered guess the decoder corrects;
- :mod:`.encoding` is what the encoder is given, :mod:`.network` is the PyTorch network and
  its losses; :mod:`weavecap.training.woven` makes the training data, trains it (resumable) and
  measures its held-out errors;
- :mod:`.infer` (encoder once, Dr.Jit decoder) and :mod:`.bsdf` (the Mitsuba BSDF at the
  footprint) render with it, through the direct-light integrator of
  :mod:`weavecap.render.direct` (its methods traced inline; the camera at pixel centres);
- :mod:`weavecap.bench.woven` is its section of ``weavecap bench --render``.

:data:`MODE` is the ``neural`` mode of ``weavecap render`` (:mod:`weavecap.render.modes`'s
table takes it); importing this package loads no Mitsuba, Dr.Jit or PyTorch until a render asks.
"""

from __future__ import annotations

from ..mode import Mode, direct_integrator

#: the neural renderer's camera samples: pixel centres (1 spp), or the centres of a grid of
#: sub-pixels (spp = n × m, each sample's footprint its sub-pixel's), so the footprints tile
#: the pixel; deterministic (Mitsuba's multi-jittered sampler without its jitter)
PIXEL_CENTRES = {"type": "multijitter", "jitter": False}


def _neural_bsdf(fabric, maps, placement, noise, linear):
    from .bsdf import NeuralSurfaceBSDF

    return NeuralSurfaceBSDF(fabric, maps, placement, noise)


#: the ``neural`` mode of ``weavecap render``
MODE = Mode("neural", "woven neural BSDF at the pixel's footprint (Chen et al. 2024), direct light",
            bsdf=_neural_bsdf, integrator=direct_integrator, fold=True, sampler=PIXEL_CENTRES, spp=4)
