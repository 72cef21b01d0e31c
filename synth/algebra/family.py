"""Continuous families of factorizations (docs/exceptional.md, section "Families of factorizations").

Two consecutive rotation factors whose primal parts are conjugate, ``h_a = ~y + eps d_a`` and
``h_b = y + eps d_b`` (equal angle laws about opposite parallel directions), multiply to a translation
(circular, or the identity when the axes coincide). Moving the two axes by the same offset keeps the
product: for every vector ``s`` perpendicular to the axis direction ``n``,

    (t - h_a + eps s)(t - h_b - eps s) = (t - h_a)(t - h_b)      [dual part changes by ~y s - s y = 2 beta n.s = 0]

So a factorization with ``p`` disjoint such pairs is one member of a ``2p``-parameter family (survey
eq. (5) for the circular translation is the case ``p = 1``). Here ``h_a -> h_a - eps s``,
``h_b -> h_b + eps s``, ``s = f e1 + g e2`` with the basis ``e1, e2`` of the plane perpendicular to the
axis (coordinate axes when the axis is a coordinate axis). Floats; factors are ``(m, 8)`` arrays.
"""
from __future__ import annotations

import numpy as np

from synth.algebra.polynomial import product_of_linear, relative_error

PAIR_TOL = 1e-9


def plane_basis(n):
    """(e1, e2), a right-handed orthonormal basis of the plane perpendicular to the unit vector n; the
    coordinate axes in cyclic order when n is (up to sign) a coordinate axis (n = +-k gives i, j)."""
    n = np.asarray(n, float)
    n = n / np.linalg.norm(n)
    c = int(np.argmax(np.abs(n)))
    if abs(abs(n[c]) - 1.0) <= 1e-12:
        e1 = np.eye(3)[(c + 1) % 3]
        e2 = np.eye(3)[(c + 2) % 3]
        return e1, e2
    a = np.eye(3)[int(np.argmin(np.abs(n)))]
    e1 = np.cross(n, a)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(n, e1)


def conjugate_pairs(factors, tol: float = PAIR_TOL) -> list[tuple[int, int]]:
    """Disjoint consecutive index pairs (i, i + 1), left to right, with primal(h_{i+1}) = conj(primal(h_i))
    (relative tolerance ``tol``) and a nonzero vector part."""
    hs = np.asarray(factors, float)
    out, i = [], 0
    while i + 1 < len(hs):
        a, b = hs[i, :4], hs[i + 1, :4]
        scale = max(1.0, float(np.linalg.norm(a)))
        conj_b = b * np.array([1.0, -1, -1, -1])
        if np.linalg.norm(a[1:]) > tol * scale and np.linalg.norm(a - conj_b) <= tol * scale:
            out.append((i, i + 1))
            i += 2
        else:
            i += 1
    return out


def factorization_family(factors) -> dict | None:
    """The family through one factorization (None when it has no conjugate pair).

    Returns {"parameters": names ["f", "g"] (one pair) or ["f1", "g1", "f2", ...], "pairs": 1-based index
    pairs, "basis": per pair [e1, e2], "factors": the base member (m, 8) as lists, "dimension": 2 p}."""
    hs = np.asarray(factors, float)
    pairs = conjugate_pairs(hs)
    if not pairs:
        return None
    names, basis = [], []
    for p, (i, _) in enumerate(pairs):
        v = hs[i, 1:4]
        e1, e2 = plane_basis(v / np.linalg.norm(v))
        basis.append([[float(x) + 0.0 for x in e1], [float(x) + 0.0 for x in e2]])
        suffix = "" if len(pairs) == 1 else str(p + 1)
        names += [f"f{suffix}", f"g{suffix}"]
    return {"parameters": names, "pairs": [[i + 1, j + 1] for i, j in pairs], "basis": basis,
            "factors": hs.tolist(), "dimension": 2 * len(pairs)}


def family_member(family: dict, values) -> np.ndarray:
    """The factors of the member with parameter ``values`` (..., 2 p) (batched): pair (a, b) gets
    h_a - eps s, h_b + eps s with s = f e1 + g e2. Returns (..., m, 8)."""
    base = np.asarray(family["factors"], float)
    values = np.asarray(values, float)
    out = np.broadcast_to(base, values.shape[:-1] + base.shape).copy()
    for p, ((a, b), (e1, e2)) in enumerate(zip(family["pairs"], family["basis"])):
        s = values[..., 2 * p, None] * np.asarray(e1) + values[..., 2 * p + 1, None] * np.asarray(e2)
        out[..., a - 1, 5:8] -= s
        out[..., b - 1, 5:8] += s
    return out


def family_residual(family: dict, values) -> np.ndarray:
    """Relative multiply-back error of members against the base product (..., ) (for checks)."""
    target = product_of_linear(np.asarray(family["factors"], float))
    return relative_error(product_of_linear(family_member(family, values)), target)


def family_text(family: dict, fmt_dq, fmt_vec) -> list[str]:
    """Lines describing the family: one per pair, ``h_a = <base> - eps s, h_b = <base> + eps s``."""
    lines = []
    base = family["factors"]
    names = family["parameters"]
    for p, ((a, b), (e1, e2)) in enumerate(zip(family["pairs"], family["basis"])):
        f, g = names[2 * p], names[2 * p + 1]
        s = f"({f} {fmt_vec(e1)} + {g} {fmt_vec(e2)})"
        lines.append(f"  h{a} = {fmt_dq(base[a - 1])} - eps s,  h{b} = {fmt_dq(base[b - 1])} + eps s,  "
                     f"s = {s} for all real {f}, {g}")
    return lines


def coincident_neighbours(factors, tol: float = PAIR_TOL) -> list[int]:
    """Indices i with t - h_i and t - h_{i+1} the same rotation (same axis and angle law): two joints on
    one line, one after the other (a link between two coaxial pins at one place)."""
    hs = np.asarray(factors, float)
    scale = max(1.0, float(np.max(np.abs(hs)))) if len(hs) else 1.0
    return [i for i in range(len(hs) - 1) if np.max(np.abs(hs[i] - hs[i + 1])) <= tol * scale]


def separate_coincident(factors):
    """Move conjugate pairs inside their family until no two consecutive factors coincide. The pair
    holding the second factor of a coincidence (else the first) gets h_a - eps s, h_b + eps s with
    s = |vec h_a| d, d the offset between the pair's axes: both axes move by n x d (n = unit(vec h_a)),
    perpendicular to d (a quarter turn of the pair's crank). The product is unchanged.
    Returns (factors (m, 8), shifted pair indices [(a, b), ...] 0-based); the input when nothing
    coincides or no pair can move."""
    hs = np.array(factors, float)
    moved = []
    for _ in range(len(hs)):
        bad = coincident_neighbours(hs)
        if not bad:
            break
        i = bad[0]
        pairs = conjugate_pairs(hs)
        pair = next((p for p in pairs if i + 1 in p and p not in moved), None) or \
            next((p for p in pairs if i in p and p not in moved), None)
        if pair is None:
            break
        a, b = pair
        v = hs[a, 1:4]
        beta = float(np.linalg.norm(v))
        pa = -np.cross(v, hs[a, 5:8]) / beta**2  # axis points (the formula holds for h_b, vector -v)
        pb = -np.cross(-v, hs[b, 5:8]) / beta**2
        d = pb - pa
        if np.linalg.norm(d) <= PAIR_TOL * max(1.0, float(np.linalg.norm(pa))):
            d = plane_basis(v / beta)[0] * max(1.0, float(np.linalg.norm(hs[:, 5:8]))) * 0.5 / beta
        s = beta * d  # moves both axes by n x d (docs/exceptional.md)
        hs[a, 5:8] -= s
        hs[b, 5:8] += s
        moved.append(pair)
    return hs, moved
