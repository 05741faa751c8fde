"""Measurement for ``weavecap bench``, apart from the code it measures: a capture or a render
imports nothing from here.

- :mod:`.model` — the forward model's speed and memory, cold and warm (``--model``);
- :mod:`.fit` — the fit bench: photos with known truth captured at each preset and scored (``--fit``);
- :mod:`.heightfield_photos` — the fit bench's independent photos, made without the forward model.
"""
