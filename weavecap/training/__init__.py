"""Training the networks weavecap ships (``weavecap train-initializer``), apart from the code
that runs them: a capture or a render imports nothing from here.

- :mod:`.trainer` — the skeleton: data shards, checkpoints and resuming, weights with their record;
- :mod:`.initializer` — the initializer's data and training (Wu et al. 2025 §5.3).
"""
