"""Hyper-parameters of the joint fit (§6.1–6.2), in one place, with the quality presets."""

from __future__ import annotations

from dataclasses import dataclass, replace


@dataclass(frozen=True)
class FitConfig:
    """Every tunable number of :func:`weavecap.fit.joint.fit`.

    Attributes
    ----------
    iterations : most gradient steps (the loop stops earlier on convergence or budget)
    cell_px : pixels per cell of the rendered repeat (the photo's repeat is resampled to the
        same cell canvas, :mod:`weavecap.estimate.cells`). At 16, a 4-spp render aliases the
        fibre grooves the photo averages: the fit bench's median PSNR at normal was 30.5 dB at
        16 px (14.9 s a photo), 31.3 dB at 24 (26.3 s)
    max_side_px : the rendered repeat's longer side is at most this (large repeats get
        smaller cells)
    spp : samples per pixel of the fitting renders: the lights are exact at any count, but
        the photo's canvas is resampled (smooth) and a 1-spp render's hard yarn edges against
        the backdrop alone cost ~25 dB of PSNR; 4 spp matches it
    learning_rate : Adam's step, in units of each parameter's Table 1 range
    barrier_lambda : λ of the range barrier, Eq. 5 (0.01 in the paper)
    anneal_t0, anneal_decay : simulated annealing's initial temperature and its decay per
        proposal (§6.2: 100 and 0.98). The paper does not give the loss's units; here the
        temperature is in basis points (0.01 %) of the current loss: a proposal that raises the
        loss by ``d`` basis points is accepted with probability ``exp(-d / T)`` — at T₀ a 1 %
        rise passes one time in e.
    anneal_every : one discrete proposal after this many gradient steps
    pattern_moves : propose flips of pattern cells (off when the pattern is given)
    pattern_sweeps : fractions of the steps after which the pattern is re-annealed (§5.1's
        batched T = 0 sweeps with the fit's current values)
    plies_scans : fractions of the steps after which the number of plies is scanned over its
        whole range with everything else fixed (:func:`weavecap.fit.joint.scan_plies`)
    plies_flat : when the first scan's loss varies by less than this share of its minimum
        over every count, the photo does not determine the plies: the start's count is held
        and no more steps go to it (measured 2–7 % on forward-model renders)
    colour_solves : fractions of the steps after which the body colours and the rig's gain
        (the photo's exposure and white balance) are solved in closed form with everything
        else fixed (:func:`weavecap.fit.joint.solve_colours`): right at the start of each
        round — each round's cells are registered first now (a solve on unregistered cells had
        set the bench's plain weave's warp black, 29.0 → 22.9 dB) and a photo brighter than
        the rig's white fabric needs its gain before any step — and late (70%)
    radius_step : first step of the radius search (and size of a radius proposal when radii
        are annealed), Algorithm 1 units; radius_min_step: the search stops below it
    radius_every : one radius search round every this many gradient steps
    converge_window, converge_tol : stop when the best loss improved by less than this
        fraction over the last ``converge_window`` steps
    registration_rounds : the capture fits in this many rounds, re-registering the photo's
        cells on the fabric fitted so far before each (:func:`weavecap.fit.rounds.fit_registered`);
        the iterations are split evenly between them
    extra_rounds, extra_round_gain : up to this many more rounds while the last one still
        lowered the loss by more than this fraction (a satin 5 of the bench: 22.6 dB after
        the three planned rounds, 28.6 dB with 300 steps)
    named_weave_tolerance : a fitted custom pattern gives way to the named weave of its shape
        (plain, twill, satin, basket, rib) when that, fitted with its pattern fixed, leaves a
        loss lower by more than this fraction, or within it either way unless the votes back
        the custom pattern (``vote_margin``): a named weave is far likelier a priori than one
        that differs from it in a cell or two
    family_colours : end each fit on the photo's own yarn colours: scale each family's body
        colours so that its mean at the centres of the cells it tops matches the photo's
        (:func:`weavecap.fit.joint.match_family_colours`, §5.2); kept when the loss rises by
        at most ``family_colour_tolerance`` (on the independent bench photos the rise was
        0–18%, median 3%; on an own-render random 3×3, 14% for 3 dB), or by more when the
        capture looks more like the photo for it (:func:`weavecap.fit.fidelity.more_faithful`:
        the worse family's colour closer, sharpness and structure no worse; or made faithful
        by ``faithful_sharpness`` and ``faithful_delta_e``, its structure higher): the MSE weighs
        every pixel alike and can trade a yarn's colour for its edges and gaps. The look is
        judged once, on the fit the stages keep (:func:`weavecap.fit.rounds.colour_check`);
        each registration round keeps its match for the loss alone
    vote_lock : a cell whose model-free vote (:mod:`weavecap.estimate.orientation`) is at
        least this decided keeps the vote's state through the fit: on the independent bench
        photos 98% of such cells were right (92% of those voted 0.3–0.5, 70% under 0.05); on
        the forward model's own renders no cell reaches it (votes ≤ 0.43)
    start_tie_tolerance : first-round starts (and the two ways of reading the drift, when they
        end on different patterns: :func:`weavecap.fit.rounds.settle_by_votes`) tie, and the
        votes choose among them, only when their losses are also within this fraction of the
        lowest: with a 2×2 repeat the paired test of
        :func:`weavecap.fit.rounds.same_within_noise` has 4 cells and called a loss 53% higher a
        tie (the real plain W027: the votes took the dual, whose weft collapsed to a thin black
        yarn and the blue was lost); the ties it settled well were 6–11% apart (on the bench and
        the real photos), the harmful ones 18–53%
    start_tie_band : starts within this fraction of the lowest loss tie even where the paired
        test tells them apart: the model differs from a real photo by more than its noise, and a
        wrong face can fit a little better (the independent twill 2/2 Z: its votes' pattern, the
        truth, fitted 6.3% above the dual's twill 3/1)
    vote_margin : the named-weave end stage keeps a custom pattern whose agreement with the
        votes (:func:`weavecap.estimate.orientation.agreement`) is more than this above the
        named weave's; a tied first-round start replaces the lowest only when the votes back it
        by more than this (the bench's plain a stop darker: votes 0.5 for both starts, the
        saying-nothing value, had handed it the dual, whose colours are the other family's)
    edge_margin : the fit ends by fitting the pattern the photo's edges decode to
        (:func:`weavecap.fit.rounds.edge_check`) when that explains the votes better than the
        fitted pattern by more than this factor (its vote misfit times it still below the
        fitted one's)
    edge_loss_cap : the decoded pattern is taken only if its loss is at most this many times
        the fitted one's (on the independent bench the right decodes rose by 1.08–1.38)
    context_margin : the fit also tries the pattern the photo's cells' looks explain best
        (:func:`weavecap.fit.rounds.context_check`) when that leaves less of their looks
        unexplained than the fitted pattern by more than this factor (on the independent
        bench's final targets, wrong context patterns explained the looks at most 1.5 times
        better than the truth, on repeats too small for the stage; the random 8×8's truth 2.1
        times better than its fit), on the product rule and ``edge_loss_cap`` as above
    widen_ratio : a fitted yarn radius under this share of the other family's is refitted at
        the other's (:func:`weavecap.fit.rounds.widen_check`; 0 never)
    phase_margin, phase_loss_tolerance : a whole-cell shift of the fitted pattern whose warp
        and weft cell centres differ in the photo's colour by more than ``phase_margin`` times
        the fitted phase's is refitted, and taken when its loss is at most
        ``1 + phase_loss_tolerance`` times the fit's (:func:`weavecap.fit.rounds.phase_check`)
    phase_min_separation : ... and only when that shift separates them by at least this
        CIEDE2000 (under it the fabric shows one colour and no phase is told apart by it)
    rig_retry : under ``--light auto``, a capture whose render is not faithful to the photo
        (below ``faithful_sharpness`` or a family beyond ``faithful_delta_e``) is captured again
        under the other rigs of :data:`weavecap.fit.rigs.BEST_RIGS`, one of them kept
        (:func:`weavecap.fit.rigs.search`); off at draft, which is for a quick look
    faithful_sharpness : a capture is faithful when its render has at least this share of the
        photo's gradient energy (the bound on real photos) ...
    faithful_delta_e : ... and each yarn family's colour is within this CIEDE2000 of the
        photo's (:func:`weavecap.fit.fidelity.fidelity`)
    rig_loss_slack : a rig search weighs ``auto``'s capture and those whose loss is at most
        this many times the lowest (:func:`weavecap.fit.rigs.kept_capture`)
    """

    iterations: int = 120
    cell_px: int = 24
    max_side_px: int = 256
    spp: int = 4
    learning_rate: float = 0.04
    barrier_lambda: float = 0.01
    anneal_t0: float = 100.0
    anneal_decay: float = 0.98
    anneal_every: int = 2
    pattern_moves: bool = True
    pattern_sweeps: tuple[float, ...] = (0.3, 0.7)
    plies_scans: tuple[float, ...] = (0.3, 0.7)
    plies_flat: float = 0.05
    colour_solves: tuple[float, ...] = (0.0, 0.7)
    radius_step: float = 0.5
    radius_min_step: float = 0.04
    radius_every: int = 6
    converge_window: int = 25
    converge_tol: float = 2e-3
    registration_rounds: int = 3
    extra_rounds: int = 3
    extra_round_gain: float = 0.05
    named_weave_tolerance: float = 0.05
    family_colours: bool = True
    family_colour_tolerance: float = 0.1
    vote_lock: float = 0.5
    vote_margin: float = 0.05
    start_tie_tolerance: float = 0.15
    start_tie_band: float = 0.10
    edge_margin: float = 1.1
    edge_loss_cap: float = 2.0
    context_margin: float = 1.5
    widen_ratio: float = 0.5
    phase_margin: float = 1.1
    phase_loss_tolerance: float = 0.1
    phase_min_separation: float = 5.0
    rig_retry: bool = True
    faithful_sharpness: float = 0.8
    faithful_delta_e: float = 10.0
    rig_loss_slack: float = 1.5

    def with_(self, **changes) -> "FitConfig":
        return replace(self, **changes)


PRESETS: dict[str, FitConfig] = {
    "draft": FitConfig(iterations=50, cell_px=10, converge_window=15, registration_rounds=2, extra_rounds=0,
                       rig_retry=False),
    "normal": FitConfig(),
    "high": FitConfig(iterations=300, spp=8, converge_window=40, converge_tol=5e-4, extra_rounds=1),
}


@dataclass(frozen=True)
class FitRequest:
    """What a caller asks of the fit of one photo (:func:`weavecap.fit.rounds.fit_registered`,
    :func:`weavecap.fit.rigs.search`), apart from the runner's own options.

    Attributes
    ----------
    quality : preset name of :data:`PRESETS`
    light : the light rig (§6.4): a rig's name, ``auto`` (chosen before the fit, searched
        further when that capture is not faithful) or ``best`` (every rig searched)
    seed : seeds every random choice; the same seed gives the same result
    budget_s : wall-time limit of the joint fit, seconds (None: the preset's iterations)
    """

    quality: str = "normal"
    light: str = "auto"
    seed: int = 0
    budget_s: float | None = None

    @property
    def config(self) -> FitConfig:
        return PRESETS[self.quality]


def cell_px_for(config: FitConfig, shape: tuple[int, int]) -> int:
    """Pixels per cell for a repeat of ``shape`` (wefts, warps) under ``config``."""
    return int(max(4, min(config.cell_px, config.max_side_px // max(shape))))
