"""numpy's LAPACK kernels for small real matrices without the wrapping of `numpy.linalg` (its checks and
conversions cost several times the factorization of a 4x8 matrix). Each function returns exactly what
its `numpy.linalg` counterpart returns (the same kernel), and defers to that counterpart when a
kernel is missing (other numpy layouts) or its result is not finite (non-convergence or non-finite
input), so errors are raised as before."""
from __future__ import annotations

import numpy as np

try:
    from numpy.linalg import _umath_linalg as _K

    _K.qr_r_raw(np.eye(2), signature="d->d")
    _OK = all(hasattr(_K, f) for f in ("qr_reduced", "eigh_lo", "svd", "svd_f"))
except Exception:  # pragma: no cover - other numpy layouts
    _OK = False


def _finite(x) -> bool:
    """A result is all finite or (non-convergence, non-finite input) has NaN in every output: one test."""
    return bool(np.isfinite(x).all())


def qr_q(a) -> np.ndarray:
    """`numpy.linalg.qr(a)[0]` (reduced Q) of a real (m, n) matrix."""
    if _OK:
        r = np.array(a, float, order="C")
        with np.errstate(all="ignore"):
            tau = _K.qr_r_raw(r, signature="d->d")
            q = _K.qr_reduced(r, tau, signature="dd->d")
        if _finite(q):
            return q
    return np.linalg.qr(a)[0]


def eigh(a) -> tuple[np.ndarray, np.ndarray]:
    """`numpy.linalg.eigh(a)` of real symmetric matrices (..., n, n): (ascending eigenvalues, vectors)."""
    if _OK:
        a = np.asarray(a, float)
        with np.errstate(all="ignore"):
            w, v = _K.eigh_lo(a, signature="d->dd")
        if _finite(w):
            return w, v
    return tuple(np.linalg.eigh(a))


def svd_values(a) -> np.ndarray:
    """`numpy.linalg.svd(a, compute_uv=False)` of real matrices (..., m, n)."""
    if _OK:
        a = np.asarray(a, float)
        with np.errstate(all="ignore"):
            s = _K.svd(a, signature="d->d")
        if _finite(s):
            return s
    return np.linalg.svd(a, compute_uv=False)


def svd(a) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """`numpy.linalg.svd(a)` (full matrices) of real matrices (..., m, n): (u, s, vh)."""
    if _OK:
        a = np.asarray(a, float)
        with np.errstate(all="ignore"):
            u, s, vh = _K.svd_f(a, signature="d->ddd")
        if _finite(s):
            return u, s, vh
    return tuple(np.linalg.svd(a))
