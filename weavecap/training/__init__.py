"""Training the networks weavecap ships (``weavecap train-initializer``, ``train-renderer``),
apart from the code that runs them: a capture or a render imports nothing from here.

- :mod:`.trainer` — the skeleton: data shards, checkpoints and resuming, weights with their record;
- :mod:`.initializer` — the initializer's data and training (Wu et al. 2025 §5.3);
- :mod:`.woven` — the woven neural renderer's data and training (Chen et al. 2024 §5);
- :mod:`.fold` — the fold renderer's LocalPT data and BLIDF training (Son et al., supplement §3–4).
"""
