"""The fold renderer (Son et al., supplement): light trapped in garment folds, learnt once.

- :mod:`.descriptors` — per-vertex fold descriptors (§4.1): the neighbourhood radius r from
  the mesh's fold scale, the polynomial surface φ_poly, the hill-valley radii φ_hv (both
  sides), the neighbourhood normal n_N; cached per mesh;
- :mod:`.localpt` — LocalPT, path tracing whose indirect bounces stay within r of the first
  hit (§4.2, the BLIDF's ground truth), as a Mitsuba integrator.
"""
