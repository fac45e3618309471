"""One step of the GP-SSM filter (Algorithm 1 of paper 000) through the compiled kernel.

:func:`step` dispatches on ``GPSSMConfig.linalg``: ``'exact'`` and ``'fast'`` run the
whole step compiled, in one call (:mod:`roadgrip.estimators.gpssm.block`);
``'direct'`` runs the NumPy reference (:mod:`roadgrip.estimators.gpssm.reference`).

BLAS runs one thread during the step (:mod:`roadgrip.blas_threads`): faster for these
small products, and the result does not depend on the number of cores (a threaded
product sums in another order, and the filter's paths part at the first resampling that
such a difference changes).
"""

from __future__ import annotations

from roadgrip.blas_threads import one_blas_thread
from roadgrip.estimators.gpssm.compiled import advance, estimate, sample_array
from roadgrip.estimators.gpssm.inputs import Sample
from roadgrip.estimators.gpssm.reference import step_reference
from roadgrip.estimators.gpssm.state import Context, GPSSMEstimate, GPSSMState

__all__ = ["step", "step_unthreaded"]


def step(
    ctx: Context, state: GPSSMState | None, sample: Sample, seed: int = 0
) -> tuple[GPSSMState, GPSSMEstimate]:
    """One step of Algorithm 1 at ``sample.t``.

    The returned state reuses (and overwrites) the arrays of ``state`` (a donated
    buffer); keep :func:`~roadgrip.estimators.gpssm.state.copy_state` of it if the old
    state is still needed. ``state=None`` initialises from ``sample`` with ``seed``.

    The ``'exact'`` and ``'fast'`` modes run the compiled whole step
    (:mod:`roadgrip.estimators.gpssm.block`); ``'direct'`` runs the NumPy reference
    implementation (:func:`~roadgrip.estimators.gpssm.reference.step_reference`). Both
    draw the same random numbers.

    BLAS runs one thread during the step (:mod:`roadgrip.blas_threads`): faster for these
    small products, and the result does not depend on the number of cores (a threaded
    product sums in another order, and the filter's paths part at the first resampling
    that such a difference changes).

    Returns
    -------
    state : GPSSMState
    estimate : GPSSMEstimate
    """
    with one_blas_thread():
        return step_unthreaded(ctx, state, sample, seed)


def step_unthreaded(
    ctx: Context, state: GPSSMState | None, sample: Sample, seed: int = 0
) -> tuple[GPSSMState, GPSSMEstimate]:
    """:func:`step` without setting the BLAS threads (for loops that set them once)."""
    if ctx.config.linalg == "direct":
        return step_reference(ctx, state, sample, seed)
    return _step_compiled(ctx, state, sample, seed)


def _step_compiled(
    ctx: Context, state: GPSSMState | None, sample: Sample, seed: int
) -> tuple[GPSSMState, GPSSMEstimate]:
    """:func:`step` through the compiled whole step (``'exact'`` and ``'fast'``), one sample."""
    new, rows = advance(ctx, state, sample_array([sample]), seed)
    return new, estimate(rows[0])
