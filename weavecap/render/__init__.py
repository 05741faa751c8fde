"""Output renderers: the captured fabric on a garment mesh (docs/design.md, "Output renderers").

- :mod:`.surface` bakes the surface model of a fabric (per-repeat maps from Algorithm 1's
  yarns), :mod:`.bsdf` shades it with the BYSDF lobes of :mod:`weavecap.model.bysdf`;
- :mod:`.mesh` reads, cleans and measures a mesh and gives it UVs at physical scale;
  :mod:`.shapes` makes the procedural fixture shapes;
- :mod:`.scene` frames a camera and lights a mesh; :mod:`.integrator` path-traces it;
  :mod:`.modes` is the table of render modes and hooks other renderers plug into;
- :mod:`.direct` is the direct-light integrator of ``--mode direct`` (the default) and ``neural``;
  :mod:`.bake_cache` keeps bakes between runs; :mod:`.garments` makes the render bench's garments;
- :mod:`.run` orders the stages for ``weavecap render``; :mod:`weavecap.bench.render` measures them.
"""
