"""The linear system of the co-factor algorithm (docs/exceptional.md): products of linear rotation
factors and primary translations whose primal parts are fixed and whose dual parts are unknown.

An `Item` is one factor of such a product: a rotation t - x - eps d (x fixed, d ⊥ vec x: 2 unknowns) or
a primary translation B + eps E (B real, E vectorial of degree < deg B: 3 deg B unknowns). The dual part
of the product is linear in the stacked unknowns (`dual_matrix`); `solve_items` gives the minimum-norm
least-squares solution and the kernel. Quaternion polynomials are arrays (deg+1, 4), ascending.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from synth.algebra.dq import qmul
from synth.algebra.geometry import perpendicular_basis
from synth.algebra.polynomial import poly_mul


def qp_mul(A, B):
    """Product of quaternion polynomials (..., na, 4) x (..., nb, 4) (ascending; order matters)."""
    return poly_mul(A, B, mul=qmul)


def as_qpoly(real):
    """A real polynomial (ascending) as a quaternion polynomial (m, 4)."""
    real = np.asarray(real, float)
    out = np.zeros((len(real), 4))
    out[:, 0] = real
    return out


def unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def perp_basis(n):
    """Two unit vectors completing the direction of n to a right-handed orthonormal basis
    (`synth.algebra.geometry.perpendicular_basis` of n / |n|)."""
    return perpendicular_basis(unit(n))


def rotation_dq(alpha, beta, n, d):
    """The dual quaternion alpha + beta n + eps d (n unit, d vector)."""
    h = np.zeros(8)
    h[0] = alpha
    h[1:4] = beta * np.asarray(n, float)
    h[5:8] = d
    return h


@dataclass
class Item:
    kind: str  # "rot" or "trans"
    primal: np.ndarray  # quaternion polynomial (deg+1, 4)
    basis: np.ndarray  # (L, deg_dual+1, 4): dual = sum_l z_l basis_l
    label: str = ""
    block: int = -1  # index of the translation block
    x: np.ndarray | None = None  # rotation primal quaternion
    perp: np.ndarray | None = None  # (2, 3) basis of d for a rotation


def rot_item(x, label=""):
    x = np.asarray(x, float)
    v = x[1:4]
    e1, e2 = perp_basis(v)
    basis = np.zeros((2, 1, 4))
    basis[0, 0, 1:] = -e1
    basis[1, 0, 1:] = -e2
    primal = np.array([-x, [1.0, 0, 0, 0]])
    return Item("rot", primal, basis, label, x=x, perp=np.array([e1, e2]))


def trans_item(B, block, label=""):
    B = np.asarray(B, float)
    deg = len(B) - 1
    basis = np.zeros((3 * deg, deg, 4))
    for c in range(deg):
        for a in range(3):
            basis[3 * c + a, c, 1 + a] = 1.0
    return Item("trans", as_qpoly(B), basis, label, block=block)


def dual_matrix(items, n):
    """Matrix A (4n x L_total) mapping the stacked unknowns to the dual part of the product of the items
    (flattened (n, 4), ascending)."""
    prim = [it.primal for it in items]
    prefix = [np.array([[1.0, 0, 0, 0]])]
    for p in prim:
        prefix.append(qp_mul(prefix[-1], p))
    suffix = [np.array([[1.0, 0, 0, 0]])]
    for p in reversed(prim):
        suffix.append(qp_mul(p, suffix[-1]))
    suffix = suffix[::-1]  # suffix[s] = product of items s.. end
    cols = []
    for s, it in enumerate(items):
        contrib = qp_mul(qp_mul(prefix[s], it.basis), suffix[s + 1])  # (L, deg, 4)
        full = np.zeros((contrib.shape[0], n, 4))
        m = min(n, contrib.shape[1])
        full[:, :m] = contrib[:, :m]
        cols.append(full.reshape(contrib.shape[0], -1).T)
    return np.concatenate(cols, axis=1), prefix[-1]


def solve_items(items, target, n):
    """Least squares for the unknowns of ``items`` so that the product's dual part is ``target`` (n, 4).
    Returns (z0 min-norm solution, kernel basis (L, dim), relative residual)."""
    A, _ = dual_matrix(items, n)
    b = np.asarray(target, float).reshape(-1)
    U, sv, Vt = np.linalg.svd(A, full_matrices=True)
    tol = 1e-10 * (sv[0] if len(sv) and sv[0] > 0 else 1.0)
    rank = int(np.sum(sv > tol))
    z0 = Vt[:rank].T @ ((U[:, :rank].T @ b) / sv[:rank])
    K = Vt[rank:].T
    r = A @ z0 - b
    scale = max(float(np.max(np.abs(b))), 1e-300)
    return z0, K, float(np.max(np.abs(r))) / scale if np.max(np.abs(b)) > 0 else float(np.max(np.abs(r)))


def split_unknowns(items, z):
    """Per item: its slice of z."""
    out, pos = [], 0
    for it in items:
        L = it.basis.shape[0]
        out.append(z[pos:pos + L])
        pos += L
    return out


def rotation_from(it, zs):
    d = zs @ it.perp
    h = np.zeros(8)
    h[:4] = it.x
    h[5:8] = d
    return h
