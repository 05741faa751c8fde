"""The fold renderer (Son et al., supplement): light trapped in garment folds, learnt once.

- :mod:`.descriptors` — per-vertex fold descriptors (§4.1): the neighbourhood radius r from
  the mesh's fold scale, the polynomial surface φ_poly, the hill-valley radii φ_hv (both
  sides), the neighbourhood normal n_N; cached per mesh;
- :mod:`.localpt` — LocalPT, path tracing whose indirect bounces stay within r of the first
  hit (§4.2, the BLIDF's ground truth), as a Mitsuba integrator;
- :mod:`.visibility` — neighbourhood visibility V̄ (§2): sampled, or ASG lobes;
- :mod:`.blidf` — the BLIDF network S_θ (factorised intensity × spherical harmonics);
- :mod:`weavecap.training.fold` — its training data (LocalPT on the procedural fold suite) and training;
- :mod:`.term` — the fold term of ``weavecap render``, :data:`TERM` here.

``weavecap.render.modes`` takes :data:`TERM` into its table when a render asks for a fold term.
"""

from ..mode import FoldTerm


def _has_folds(mesh) -> bool:
    from .term import has_folds

    return has_folds(mesh)


def _apply(context):
    from .term import apply

    return apply(context)


#: the fold term of ``weavecap render`` (the BLIDF's local inter-reflection)
TERM = FoldTerm("blidf", _has_folds, _apply)
