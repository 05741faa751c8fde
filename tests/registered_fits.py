"""A faked round of the fit, for the tests of its end stages (:mod:`weavecap.fit.rounds`); a
module of its own, shared by ``fit/test_target.py`` and ``estimate/test_context.py``."""

from __future__ import annotations


def registered_fit(fabric, loss, *, target):
    """A :class:`weavecap.fit.rounds.RegisteredFit` of ``fabric`` at ``loss`` on ``target``, as
    a faked round returns it."""
    from weavecap.fit import rounds
    from weavecap.fit.joint import FitResult

    result = FitResult(fabric=fabric, loss=loss, history=[loss], iterations=1, seconds=0.0, stopped="iterations")
    return rounds.RegisteredFit(result=result, target=target, cells=None, blur_px=0.0)
