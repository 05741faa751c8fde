"""Hyper-parameters of the joint fit (§6.1–6.2), in one place, with the quality presets."""

from __future__ import annotations

from dataclasses import dataclass, replace


@dataclass(frozen=True)
class FitConfig:
    """Every tunable number of :func:`weavecap.fit.joint.fit`.

    Attributes
    ----------
    iterations : most gradient steps (the loop stops earlier on convergence or budget)
    size : pixels along the longer side of the rendered repeat (the photo's repeat is
        resampled to it)
    spp : samples per pixel of the fitting renders (directional lights: 1 is exact at pixel
        centres; more only antialiases yarn edges)
    learning_rate : Adam's step, in units of each parameter's Table 1 range
    barrier_lambda : λ of the range barrier, Eq. 5 (0.01 in the paper)
    anneal_t0, anneal_decay : simulated annealing's initial temperature and its decay per
        proposal (§6.2: 100 and 0.98). The paper does not give the loss's units; here the
        temperature is in basis points (0.01 %) of the current loss: a proposal that raises the
        loss by ``d`` basis points is accepted with probability ``exp(-d / T)`` — at T₀ a 1 %
        rise passes one time in e.
    anneal_every : one discrete proposal after this many gradient steps
    pattern_moves : propose flips of pattern cells (off when the pattern is given)
    radius_step : size of a radius proposal, Algorithm 1 units
    converge_window, converge_tol : stop when the best loss improved by less than this
        fraction over the last ``converge_window`` steps
    """

    iterations: int = 120
    size: int = 96
    spp: int = 1
    learning_rate: float = 0.04
    barrier_lambda: float = 0.01
    anneal_t0: float = 100.0
    anneal_decay: float = 0.98
    anneal_every: int = 2
    pattern_moves: bool = True
    radius_step: float = 0.25
    converge_window: int = 25
    converge_tol: float = 2e-3

    def with_(self, **changes) -> "FitConfig":
        return replace(self, **changes)


PRESETS: dict[str, FitConfig] = {
    "draft": FitConfig(iterations=50, size=64, converge_window=15),
    "normal": FitConfig(),
    "high": FitConfig(iterations=300, size=128, spp=2, converge_window=40, converge_tol=5e-4),
}
