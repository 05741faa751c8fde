"""weavecap: one close-up photo of a woven fabric in, a renderable fabric out.

The pipeline follows Wu et al. 2025, *Automatic Reconstruction of Woven Cloth from a Single
Close-up Image* (``../shared/papers/001_*.txt``). Mitsuba is reached only through
:func:`weavecap.backend.mitsuba`, which picks the libLLVM before Dr.Jit loads. Importing
weavecap already points Dr.Jit at that library (:func:`weavecap.backend.prefer_llvm`), so a
script may import drjit or mitsuba after it.
"""

__version__ = "0.1.0"

from .backend import prefer_llvm  # noqa: E402

prefer_llvm()
