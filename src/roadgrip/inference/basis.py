r"""Reduced-rank Gaussian-process bases (Hilbert-space method) and spectral densities.

Solin & Särkkä (2014) approximate a stationary kernel on the box ``[-L, L]^d`` by the
eigenfunctions of the Laplace operator with Dirichlet boundary conditions
(paper 000, eq. 9-10):

.. math::

    \kappa(x, x') \approx \sum_j S(\sqrt{\lambda_j})\, \phi_j(x) \phi_j(x'), \qquad
    \lambda_j = \sum_n \Big(\frac{\pi j_n}{2 L}\Big)^2, \qquad
    \phi_j(x) = \prod_n \frac{1}{\sqrt{L}} \sin\Big(\frac{\pi j_n (x_n + L)}{2 L}\Big),

where ``S`` is the spectral density of the kernel (a function of the angular frequency
``omega = sqrt(lambda)``). A function ``f = sum_j gamma_j phi_j`` with
``gamma_j ~ N(0, S(sqrt(lambda_j)))`` is then (approximately) a draw from the GP.

Every basis here returns *whitened* features ``phi_j(x) sqrt(S_j)``, so that the weights
have a standard-normal prior (``V = I`` in the MNIW prior of :mod:`roadgrip.estimators.mniw`);
``A_paper = A_white diag(sqrt(S))^{-1}``.

Two bases over the axle slip angles ``alpha = (alpha_f, alpha_r)`` [rad]:

``TensorBasis``
    the paper's 2-D tensor basis, ``n x n`` products of 1-D eigenfunctions of
    ``alpha_f`` and ``alpha_r`` with the 2-D spectral density; one feature vector for
    both axles (one MNIW group with two outputs).
``SeparableBasis``
    ``n`` 1-D functions of ``alpha_f`` for the front axle and ``n`` of ``alpha_r`` for
    the rear axle (two MNIW groups with one output each; see
    :mod:`roadgrip.estimators.gpssm` for how this stays conjugate).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "KERNELS",
    "SeparableBasis",
    "TensorBasis",
    "eigenfunctions_1d",
    "eigenvalues_1d",
    "kernel_exact",
    "make_basis",
    "spectral_density",
]

KERNELS = ("se", "matern52")


def eigenvalues_1d(n: int, L: float) -> NDArray[np.float64]:
    """``lambda_j = (pi j / (2 L))^2`` for ``j = 1..n`` [1/rad²] (eq. 10a, one dimension)."""
    j = np.arange(1, n + 1, dtype=float)
    return (np.pi * j / (2.0 * L)) ** 2


def eigenfunctions_1d(x: ArrayLike, n: int, L: float) -> NDArray[np.float64]:
    """``phi_j(x) = sin(pi j (x + L) / (2 L)) / sqrt(L)`` (eq. 10b), shape ``x.shape + (n,)``.

    Points outside ``[-L, L]`` are clipped to the boundary, where every function is zero.
    """
    x = np.clip(np.asarray(x, dtype=float), -L, L)
    j = np.arange(1, n + 1, dtype=float)
    return np.sin(np.pi * j * (x[..., None] + L) / (2.0 * L)) / np.sqrt(L)


def spectral_density(
    omega: ArrayLike, kernel: str, s_f: float, ell: float, dim: int
) -> NDArray[np.float64]:
    r"""Spectral density ``S(omega)`` of an isotropic kernel in ``dim`` dimensions.

    ``se``:  ``s_f (2 pi ell²)^{d/2} exp(-ell² omega² / 2)`` for
    ``k(r) = s_f exp(-r² / (2 ell²))``.

    ``matern52``:  ``s_f 2^d pi^{d/2} Gamma(nu + d/2) (2 nu)^nu / (Gamma(nu) ell^{2 nu})
    (2 nu / ell² + omega²)^{-(nu + d/2)}`` with ``nu = 5/2`` (Rasmussen & Williams 2006,
    eq. 4.15).

    Parameters
    ----------
    omega : array_like
        Angular frequency [1/rad].
    kernel : {'se', 'matern52'}
    s_f : float
        Kernel variance (value at ``r = 0``).
    ell : float
        Length scale [rad].
    dim : int
        Input dimension ``d``.
    """
    w2 = np.asarray(omega, dtype=float) ** 2
    if kernel == "se":
        return s_f * (2.0 * np.pi * ell**2) ** (dim / 2.0) * np.exp(-0.5 * ell**2 * w2)
    if kernel == "matern52":
        nu = 2.5
        c = (
            2.0**dim * np.pi ** (dim / 2.0) * math.gamma(nu + dim / 2.0) * (2.0 * nu) ** nu
            / (math.gamma(nu) * ell ** (2.0 * nu))
        )
        return s_f * c * (2.0 * nu / ell**2 + w2) ** (-(nu + dim / 2.0))
    raise ValueError(f"unknown kernel {kernel!r}; expected one of {KERNELS}")


def kernel_exact(r: ArrayLike, kernel: str, s_f: float, ell: float) -> NDArray[np.float64]:
    """The exact isotropic kernel ``k(r)`` at distance ``r`` [rad] (for tests and plots)."""
    r = np.abs(np.asarray(r, dtype=float))
    if kernel == "se":
        return s_f * np.exp(-0.5 * (r / ell) ** 2)
    if kernel == "matern52":
        z = np.sqrt(5.0) * r / ell
        return s_f * (1.0 + z + z**2 / 3.0) * np.exp(-z)
    raise ValueError(f"unknown kernel {kernel!r}; expected one of {KERNELS}")


def _check(n: int, L: float, s_f: float, ell: float, kernel: str) -> None:
    if int(n) != n or n < 1:
        raise ValueError(f"number of basis functions per dimension must be >= 1, got {n!r}")
    for name, v in (("L", L), ("s_f", s_f), ("ell", ell)):
        if not np.isfinite(v) or v <= 0:
            raise ValueError(f"basis parameter {name} must be positive and finite, got {v!r}")
    if kernel not in KERNELS:
        raise ValueError(f"unknown kernel {kernel!r}; expected one of {KERNELS}")


@dataclass(frozen=True)
class TensorBasis:
    """``n x n`` tensor basis over ``(alpha_f, alpha_r)`` in ``[-L, L]²`` (paper 000).

    One feature vector of length ``m = n²`` serves both axles (``groups = 1``, ``outputs = 2``).

    Parameters
    ----------
    n : int
        Functions per slip dimension (paper: 10).
    L : float
        Half-width of the domain [rad] (paper: 30 deg).
    s_f : float
        Kernel variance (see :class:`roadgrip.estimators.gpssm.config.GPSSMConfig` for its scale).
    ell : float
        Length scale [rad] (paper: 2 deg).
    kernel : {'se', 'matern52'}
    """

    n: int = 10
    L: float = math.radians(30.0)
    s_f: float = 500.0
    ell: float = math.radians(2.0)
    kernel: str = "se"
    odd: bool = False

    def __post_init__(self) -> None:
        _check(self.n, self.L, self.s_f, self.ell, self.kernel)

    kind = "tensor"
    groups = 1
    outputs = 2

    @cached_property
    def _keep(self) -> NDArray[np.bool_]:
        # odd=True keeps products with j1 + j2 odd: mu(-a_f, -a_r) = -mu(a_f, a_r)
        j = np.arange(1, self.n + 1)
        keep = np.ones((self.n, self.n), dtype=bool)
        if self.odd:
            keep = (j[:, None] + j[None, :]) % 2 == 1
        return keep.ravel()

    @property
    def m(self) -> int:
        """Features per group (``n²``, about half of it with ``odd``)."""
        return int(self._keep.sum())

    @cached_property
    def sqrt_s(self) -> NDArray[np.float64]:
        """``sqrt(S(sqrt(lambda_j)))`` in feature order (front index major), shape (m,)."""
        lam = eigenvalues_1d(self.n, self.L)
        lam2 = (lam[:, None] + lam[None, :]).ravel()[self._keep]
        return np.sqrt(spectral_density(np.sqrt(lam2), self.kernel, self.s_f, self.ell, 2))

    def features(self, alpha_f: ArrayLike, alpha_r: ArrayLike) -> NDArray[np.float64]:
        """Whitened features, shape ``broadcast(alpha_f, alpha_r).shape + (1, m)``."""
        pf = eigenfunctions_1d(alpha_f, self.n, self.L)
        pr = eigenfunctions_1d(alpha_r, self.n, self.L)
        pf, pr = np.broadcast_arrays(pf, pr)
        phi = (pf[..., :, None] * pr[..., None, :]).reshape((*pf.shape[:-1], self.n * self.n))
        if self.odd:
            phi = phi[..., self._keep]
        return (phi * self.sqrt_s)[..., None, :]

    def label(self) -> str:
        return f"tensor{'-odd' if self.odd else ''}:{self.n}x{self.n}"


@dataclass(frozen=True)
class SeparableBasis:
    """``n`` functions of ``alpha_f`` (front) and ``n`` of ``alpha_r`` (rear), 1-D spectra.

    Two groups of ``m = n`` features with one output each: the front friction depends on
    ``alpha_f`` only and the rear friction on ``alpha_r`` only.
    """

    n: int = 20
    L: float = math.radians(30.0)
    s_f: float = 500.0
    ell: float = math.radians(2.0)
    kernel: str = "se"
    odd: bool = False

    def __post_init__(self) -> None:
        _check(self.n, self.L, self.s_f, self.ell, self.kernel)

    kind = "separable"
    groups = 2
    outputs = 1

    @property
    def m(self) -> int:
        return self.n

    @cached_property
    def _j(self) -> NDArray[np.int64]:
        # odd=True keeps the eigenfunctions with even j, which are odd in alpha
        return np.arange(1, 2 * self.n + 1)[1::2] if self.odd else np.arange(1, self.n + 1)

    @cached_property
    def sqrt_s(self) -> NDArray[np.float64]:
        lam = eigenvalues_1d(2 * self.n if self.odd else self.n, self.L)[self._j - 1]
        return np.sqrt(spectral_density(np.sqrt(lam), self.kernel, self.s_f, self.ell, 1))

    def features(self, alpha_f: ArrayLike, alpha_r: ArrayLike) -> NDArray[np.float64]:
        """Whitened features, shape ``broadcast.shape + (2, m)`` (group 0 front, 1 rear)."""
        nn = 2 * self.n if self.odd else self.n
        pf = eigenfunctions_1d(alpha_f, nn, self.L)[..., self._j - 1]
        pr = eigenfunctions_1d(alpha_r, nn, self.L)[..., self._j - 1]
        pf, pr = np.broadcast_arrays(pf, pr)
        return np.stack([pf, pr], axis=-2) * self.sqrt_s

    def label(self) -> str:
        return f"separable{'-odd' if self.odd else ''}:{self.n}"


def make_basis(
    spec: str,
    *,
    L: float = math.radians(30.0),
    s_f: float = 500.0,
    ell: float = math.radians(2.0),
    kernel: str = "se",
) -> TensorBasis | SeparableBasis:
    """Parse ``'tensor:10x10'``, ``'separable:20'`` or ``'separable-odd:20'``.

    A missing size is the paper's (``'tensor'`` is ``'tensor:10x10'``, ``'separable'``
    ``'separable:20'``). The ``-odd`` variants keep only the eigenfunctions
    (products) that are odd in the slip angles, ``mu(-alpha) = -mu(alpha)`` and
    ``mu(0) = 0``: a tire and vehicle symmetric left to right. With it a bias of the
    lateral-velocity estimate (which shifts both turning directions the same way) no
    longer fits the data, so the slip angles become identifiable.
    """
    if not isinstance(spec, str):
        raise ValueError(f"bad basis {spec!r}: expected a string such as 'separable-odd:20'")
    kind, _, size = spec.partition(":")
    try:
        if kind in ("tensor", "tensor-odd"):
            a, _, b = (size or "10x10").partition("x")
            if int(a) != int(b or a):
                raise ValueError("the tensor basis needs the same count on both axes")
            return TensorBasis(int(a), L, s_f, ell, kernel, kind == "tensor-odd")
        if kind in ("separable", "separable-odd"):
            return SeparableBasis(int(size or 20), L, s_f, ell, kernel, kind == "separable-odd")
    except ValueError as exc:
        raise ValueError(f"bad basis {spec!r}: {exc}") from None
    raise ValueError(
        f"bad basis {spec!r}: expected 'tensor:NxN', 'separable:N' or their '-odd' variants"
    )
