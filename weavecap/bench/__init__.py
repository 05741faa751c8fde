"""Measurement for ``weavecap bench``, apart from the code it measures: a capture or a render
imports nothing from here.

- :mod:`.model` — the forward model's speed and memory, cold and warm (``--model``);
- :mod:`.fit` — the fit bench: photos with known truth captured at each preset and scored (``--fit``);
- :mod:`.heightfield_photos` — the fit bench's independent photos, made without the forward model;
- :mod:`.render` — the output renderers (``--render``): its sections' registry, the reference
  path tracer against Mitsuba's, the flat swatch against ``synth``; the sections :mod:`.woven`
  (the woven neural renderer), :mod:`.fold` (the fold term against LocalPT and path tracing)
  and :mod:`.agreement` (garments and lights never trained on: neural against direct, the fold
  term against path tracing).
- :mod:`.sections` — `weavecap bench`'s sections in order, their tables;
- :mod:`.real` — the real-photo development bench (``--fit --set real``): photos of real fabrics
  scored against their labels, DEV and HELD-OUT apart.
"""
