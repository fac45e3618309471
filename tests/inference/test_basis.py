"""Reduced-rank GP bases (roadgrip.inference.basis)."""

import itertools
import math

import numpy as np
import pytest
from scipy.integrate import quad

from roadgrip.inference.basis import (
    SeparableBasis,
    TensorBasis,
    eigenfunctions_1d,
    kernel_exact,
    make_basis,
    spectral_density,
)


@pytest.mark.parametrize("kernel", ["se", "matern52"])
def test_spectral_density_is_fourier_transform_of_kernel(kernel):
    # 1-D: S(w) = int k(r) cos(w r) dr
    s_f, ell = 2.0, 0.3
    for w in (0.0, 1.0, 5.0):
        num, _ = quad(lambda r, w=w: kernel_exact(r, kernel, s_f, ell) * math.cos(w * r), -20, 20,
                      limit=400)
        assert spectral_density(w, kernel, s_f, ell, 1) == pytest.approx(num, rel=1e-6)


def test_eigenfunctions_orthonormal_on_domain():
    L = 0.5
    x = np.linspace(-L, L, 20001)
    phi = eigenfunctions_1d(x, 8, L)
    gram = np.trapezoid(phi[:, :, None] * phi[:, None, :], x, axis=0)
    np.testing.assert_allclose(gram, np.eye(8), atol=1e-6)


@pytest.mark.parametrize("kernel", ["se", "matern52"])
def test_reduced_rank_kernel_converges_to_exact(kernel):
    L, ell, s_f = math.radians(30), math.radians(4), 1.0
    x = np.radians(np.linspace(-10, 10, 41))
    exact = kernel_exact(x[:, None] - x[None, :], kernel, s_f, ell)
    errs = []
    for n in (8, 16, 32, 64, 128):
        b = SeparableBasis(n=n, L=L, s_f=s_f, ell=ell, kernel=kernel)
        f = b.features(x, x)[:, 0, :]
        errs.append(np.abs(f @ f.T - exact).max())
    assert all(e2 <= e1 + 1e-14 for e1, e2 in itertools.pairwise(errs))
    assert errs[0] > 0.05  # eight functions are far from the kernel
    assert errs[-1] < (1e-12 if kernel == "se" else 1e-5)


def test_tensor_basis_approximates_2d_kernel():
    L, ell = math.radians(30), math.radians(6)
    b = TensorBasis(n=40, L=L, s_f=1.0, ell=ell)
    pts = np.radians(np.array([[0.0, 0.0], [3.0, 1.0], [-5.0, 4.0], [8.0, -2.0]]))
    f = b.features(pts[:, 0], pts[:, 1])[:, 0, :]
    r = np.linalg.norm(pts[:, None] - pts[None], axis=-1)
    np.testing.assert_allclose(f @ f.T, kernel_exact(r, "se", 1.0, ell), atol=2e-3)
    assert b.m == 1600 and f.shape == (4, 1600)


def test_make_basis_parses_and_rejects():
    assert make_basis("tensor") == TensorBasis(10)
    assert make_basis("tensor:6x6").m == 36
    sep = make_basis("separable:12")
    assert (sep.groups, sep.outputs, sep.m) == (2, 1, 12)
    for bad in ("tensor:3x4", "separable:x", "radial:5", "tensor:0x0", None):
        with pytest.raises(ValueError, match="bad basis"):
            make_basis(bad)
