"""weavecap: one close-up photo of a woven fabric in, a renderable fabric out.

The pipeline follows Wu et al. 2025, *Automatic Reconstruction of Woven Cloth from a Single
Close-up Image* (``../shared/papers/001_*.txt``). Mitsuba is reached only through
:func:`weavecap.backend.mitsuba`, which picks the libLLVM before Dr.Jit loads.
"""

__version__ = "0.1.0"
