"""Linkages that perform a rational motion or draw a rational curve (issue 5; docs/exceptional.md).

``motion_linkage(C)``: C (monic after normalization, bounded) -> C R = (t - h_1)...(t - h_N) by the
co-factor algorithm -> the ladder of Bennett flips from one extra rotation m0 (chosen automatically).
The link ``coupler`` moves by C (the motion is not changed by the real co-factor R). A general Darboux
motion gets the 7R loop of `synth.synthesis.darboux` instead (7 joints, fewer than any ladder of it).

``curve_linkage(x, y, z, w)``: the point (x/w, y/w, z/w) (polynomials in t, w without real zero, deg x, y,
z <= deg w). The curvilinear translation C_T = w + eps F, F = -(X - p0 w)/2, moves the point p0 = X/w at
t = infinity along the curve. Two motions are tried:
- ``translation``: C_T R (real co-factor);
- ``rotation``: C_T H, H = prod (t - x_i) a rotation about an axis through p0 (one factor per quadratic
  factor of w, all coaxial), as in the survey's ellipse linkage (Gallet et al.). H fixes p0, so p0 still
  draws the curve, and for planar curves (axis normal to the plane) C_T H factors with R = 1: the
  ellipse gives 3 rotations -> 10 joints instead of 13.
``auto`` keeps the one with fewer joints. The drawing point is the frame ``tracer`` fixed to the coupler
at p0 (``linkage.info.synthesis.markers``, written by the URDF exporter as link ``tracer`` + fixed joint).
"""
from __future__ import annotations

from fractions import Fraction

import numpy as np

from synth.algebra.cofactor import CofactorResult, factorize_with_cofactor
from synth.algebra.exact import real_divmod, real_root_count
from synth.algebra.expr import exact_floats
from synth.algebra.family import conjugate_pairs, separate_coincident
from synth.algebra.flip import parallelogram_flip
from synth.algebra.geometry import perpendicular_basis
from synth.errors import InputError, SynthesisError
from synth.synthesis.darboux import DARBOUX_JOINTS, darboux_linkage
from synth.info import (Alternative, CouplerMotion, CurveRecord, GivenMotion, LinkageInfo, Marker, MultiLoop,
                        Parallelogram)
from synth.linkage import Linkage
from synth.task import CurveSpec
from synth.algebra.realfactor import UnboundedMotionError, poly_text, real_gcd_exact, real_gcd_numeric

CHECK_SAMPLES = 200


class UnboundedCurveError(SynthesisError):
    """w has a real zero (or deg x > deg w): the curve runs to infinity."""


# ====================================================================== motions
def _frac_rows(C):
    if isinstance(C, np.ndarray):
        return None
    rows = [list(r) for r in C]
    if all(isinstance(x, (int, Fraction)) and not isinstance(x, bool) for r in rows for x in r):
        return [[Fraction(x) for x in r] for r in rows]
    return None


def normalize_motion(C, scale: float = 1.0):
    """(C' monic (float), C' exact or None, leading coefficient c (8,), real content g): C = g C' c in
    the sense of motions (pose(C(t)) = pose(C'(t)) @ pose(c)); dual parts multiplied by ``scale``
    (length unit -> metres). Raises InputError for a constant or non-motion polynomial."""
    from synth.algebra.dq import dq_inv, dq_mul
    from synth.algebra.polynomial import study_residual

    exact = _frac_rows(C)
    if exact is not None:
        rows = [list(r) for r in exact]
        while len(rows) > 1 and all(v == 0 for v in rows[-1]):
            rows.pop()
        Cf = exact_floats(rows, "motion")
    else:
        Cf = np.asarray(C, float)
        if Cf.ndim != 2 or Cf.shape[1] != 8:
            raise InputError(f"a motion polynomial needs rows of 8 numbers, got shape {Cf.shape}")
        nz = np.flatnonzero(np.any(Cf != 0, axis=1))
        Cf = Cf[: (nz[-1] + 1 if len(nz) else 1)]
        rows = None
    if not np.all(np.isfinite(Cf)):
        raise InputError("the motion polynomial has non-finite coefficients")
    if Cf.shape[0] < 2:
        raise InputError("the motion polynomial is constant (degree 0): it does not move")
    lead = Cf[-1]
    if np.linalg.norm(lead[:4]) <= 1e-12 * max(1.0, float(np.max(np.abs(Cf)))):
        raise InputError("the leading coefficient of the motion polynomial has zero primal part "
                         "(not invertible): write the motion with an invertible leading coefficient")
    res = float(study_residual(Cf))
    if res > 1e-9:
        raise InputError(f"not a motion polynomial: its norm polynomial is not real (Study condition "
                         f"violated by {res:.2g})")
    Cn = np.asarray(dq_mul(Cf, dq_inv(lead)))  # C c^-1: monic, pose(C) = pose(C c^-1) @ pose(c)
    Cn[-1] = np.eye(8)[0]
    Cn[:, 4:] *= scale
    lead = lead.copy()
    lead[4:] *= scale
    exact_n = None
    if rows is not None and all(v == 0 for v in rows[-1][1:]) and rows[-1][0] != 0 and scale == 1.0:
        exact_n = [[v / rows[-1][0] for v in r] for r in rows]
    # real content (same motion): gcd of all 8 components
    if exact_n is not None:
        g, _ = real_gcd_exact(exact_n)
        if len(g) > 1:
            new = [_exact_quotient([r[col] for r in exact_n], g) for col in range(8)]
            deg = len(exact_n) - len(g)
            exact_n = [[(new[c][k] if k < len(new[c]) else Fraction(0)) for c in range(8)] for k in range(deg + 1)]
            Cn = np.array([[float(x) for x in r] for r in exact_n])
    else:
        g = real_gcd_numeric(Cn)
        if len(g) > 1:
            from synth.algebra.realpoly import divide_real

            Cn = divide_real(Cn, np.asarray(g, float))
            Cn[-1] = np.eye(8)[0]
    if Cn.shape[0] < 2:
        raise InputError("the motion polynomial is a real multiple of a constant: it does not move")
    return Cn, exact_n, lead, np.array([float(x) for x in g])


def _ladder(factors, coupler_motion, kind, info, tool_ref, markers=None, m0=None, seed=0):
    from synth.checks import self_check
    from synth.synthesis.multiloop import choose_m0, ladder_linkage, score_linkage

    def build(m):
        lk = ladder_linkage(factors, m, kind=kind, motion=coupler_motion, tool_ref=tool_ref, info=info)
        if markers:
            lk.info = lk.info.with_synthesis(markers=markers)
        return lk

    if m0 is None:
        m0, lk, score = choose_m0(factors, build=build, seed=seed)
    else:
        lk = build(np.asarray(m0, float))
        score = score_linkage(lk)
    lk.info = lk.info.with_synthesis(m0=tuple(float(x) for x in m0), mobility=score, counts=lk.counts())
    lk.checks = self_check(lk, CHECK_SAMPLES)
    return lk


def is_parallelogram(factors) -> bool:
    """Two factors with conjugate primal parts and distinct axes: a circular translation, built as a
    parallelogram (4 joints) from two members of its family (docs/exceptional.md)."""
    hs = np.asarray(factors, float)
    if len(hs) != 2 or conjugate_pairs(hs) != [(0, 1)]:
        return False
    try:
        parallelogram_flip(hs[0], hs[1])
    except SynthesisError:
        return False
    return True


def joint_count(factors) -> int:
    """Joints of the linkage built for these factors: 4 for a parallelogram, else the ladder's 3 N + 1."""
    return 4 if is_parallelogram(factors) else 3 * len(factors) + 1


def _parallelogram(factors, coupler_motion, kind, info, tool_ref, markers=None):
    """The 4R parallelogram of a circular translation (t - h1)(t - h2) = (t - k1)(t - k2): branch h is
    the given factorization, branch k the member of its family from `parallelogram_flip` (the other pair
    of axes turned about the crank by an angle with cos 3/5, a rhombus). The coupler translates."""
    from synth.checks import self_check
    from synth.synthesis.assemble import two_branch_linkage
    from synth.synthesis.multiloop import score_linkage

    hs = np.asarray(factors, float)
    k1, k2, s = parallelogram_flip(hs[0], hs[1])
    lk = two_branch_linkage(kind, hs, np.array([k1, k2]), coupler_motion, [tool_ref], [], [])
    shape = Parallelogram(h=hs, k=np.array([k1, k2]), shift=s,
                          family="k1 = h1 - eps s, k2 = h2 + eps s, s perpendicular to the axes")
    lk.info = LinkageInfo(synthesis=info.replace(markers=markers or None, parallelogram=shape,
                                                 mobility=score_linkage(lk), counts=lk.counts()))
    lk.checks = self_check(lk, CHECK_SAMPLES)
    return lk


def _build(factors, coupler_motion, kind, info, tool_ref, markers=None, m0=None, seed=0):
    """The parallelogram for a circular translation (unless ``m0`` asks for the ladder), else the ladder."""
    if m0 is None and is_parallelogram(factors):
        return _parallelogram(factors, coupler_motion, kind, info, tool_ref, markers)
    # two equal consecutive factors would put two pins on one line of one link (the vertical Darboux
    # motion's C (t^2 + 1) has them): move a conjugate pair inside its family (same product)
    factors, moved = separate_coincident(factors)
    if moved:
        info = info.replace(separated_pairs=tuple((a + 1, b + 1) for a, b in moved))
    return _ladder(factors, coupler_motion, kind, info, tool_ref, markers=markers, m0=m0, seed=seed)


def motion_linkage(C, *, scale: float = 1.0, m0=None, seed: int = 0, text: str | None = None) -> Linkage:
    """The multi-loop linkage (kind "motion") whose ``coupler`` performs the rational motion C (rows of 8
    numbers, ascending; Fractions allowed). ``scale``: length unit -> metres. Raises InputError,
    UnboundedMotionError ("needs a sliding joint") or SynthesisError."""
    from synth.algebra.dq import dq_to_pose
    from synth.algebra.polynomial import poly_mul

    Cn, exact_n, lead, g_real = normalize_motion(C, scale)
    res = factorize_with_cofactor(exact_n if exact_n is not None else Cn)
    R8 = np.zeros((len(res.R), 8))
    R8[:, 0] = res.R
    given = GivenMotion(input=tuple(tuple(float(x) for x in r) for r in C), expression=text, monic=Cn,
                        leading_coefficient=lead, real_content=g_real, cofactor=res.R, cofactor_text=poly_text(res.R),
                        deg_R=res.deg_R, mrpf=res.g, mrpf_text=poly_text(res.g), bound_met=res.bound_met,
                        factorization_residual=res.residual, components=tuple(_plain_report(r) for r in res.report),
                        C_times_R=poly_mul(Cn, R8))
    info = MultiLoop(motion=given)
    tool_ref = dq_to_pose(lead / np.linalg.norm(lead[:4]))
    if m0 is None and joint_count(res.factors) > DARBOUX_JOINTS:  # the smaller linkage: a Darboux 7R
        lk = darboux_linkage(Cn, tool_ref=tool_ref, info=info, check_samples=CHECK_SAMPLES)
        if lk is not None:
            alternatives = (Alternative(method="darboux 7R", joints=DARBOUX_JOINTS),
                            Alternative(method="ladder", joints=joint_count(res.factors)))
            lk.info = lk.info.with_synthesis(motion=given.replace(alternatives=alternatives))
            return lk
    return _build(res.factors, Cn, "motion", info, tool_ref, m0=m0, seed=seed)


def _plain_report(rep):
    return {k: v for k, v in rep.items() if k != "family"}


# ====================================================================== curves
def _poly_float(c):
    return exact_floats(list(c), "curve")


def _exact_quotient(p, g) -> list[Fraction]:
    """p / g over Q (ascending; g divides p exactly), at least one coefficient long."""
    q, r = real_divmod(p, g)
    assert not r, "g must divide p"
    return q or [Fraction(0)]


def reduce_curve(polys):
    """Divide x, y, z, w (ascending Fractions or floats) by their common factor, make w monic. Returns
    (X (3, deg w + 1) floats, w floats, exact lists or None)."""
    exact = all(isinstance(v, (int, Fraction)) and not isinstance(v, bool) for p in polys for v in p)
    deg = max(len(p) for p in polys) - 1
    if exact:
        cols = [[Fraction(p[k]) if k < len(p) else Fraction(0) for p in polys] for k in range(deg + 1)]
        if all(v == 0 for v in polys[3]):
            raise InputError("curve: w is zero")
        g, _ = real_gcd_exact(cols)
        if len(g) > 1:
            polys = [_exact_quotient([Fraction(x) for x in p], g) for p in polys]
        polys = [[Fraction(v) for v in p] for p in polys]
        for p in polys:
            while len(p) > 1 and p[-1] == 0:
                p.pop()
        lw = polys[3][-1]
        polys = [[v / lw for v in p] for p in polys]
    else:
        polys = [list(map(float, p)) for p in polys]
        if not any(polys[3]):
            raise InputError("curve: w is zero")
        for p in polys:
            while len(p) > 1 and p[-1] == 0:
                p.pop()
        lw = polys[3][-1]
        polys = [[v / lw for v in p] for p in polys]
    return polys, exact


def curve_translation(polys, scale: float = 1.0):
    """(C_T (deg w + 1, 8) floats, p0 (3,) metres, w floats, X (3, deg w + 1) metres) for the reduced
    curve; raises UnboundedCurveError / InputError."""
    polys, exact = reduce_curve(polys)
    w = polys[3]
    dw = len(w) - 1
    for name, p in zip("xyz", polys[:3]):
        if len(p) - 1 > dw:
            raise UnboundedCurveError(f"unbounded curve: deg {name} = {len(p) - 1} exceeds deg w = {dw}, "
                                      "so the point runs to infinity as t -> infinity")
    if dw == 0:
        raise InputError("the curve is a single point (after cancelling common factors, x, y, z and w are "
                         "constants)")
    if exact:
        if real_root_count(w) > 0:
            import sympy  # only to name the zeros in the message

            W = sympy.Poly([sympy.Rational(x.numerator, x.denominator) for x in reversed(w)], sympy.Symbol("t"))
            roots = [float(r) for r in sympy.real_roots(W)]
            raise UnboundedCurveError("unbounded curve: w has a real zero at t = "
                                      + ", ".join(f"{r:.6g}" for r in sorted(set(roots))))
    else:
        z = np.roots(np.array(w, float)[::-1])
        real = z[np.abs(z.imag) <= 1e-7 * np.maximum(1, np.abs(z))]
        if len(real):
            raise UnboundedCurveError("unbounded curve: w has a real zero at t = "
                                      + ", ".join(f"{r.real:.6g}" for r in real))
    wf = _poly_float(w)
    X = np.zeros((3, dw + 1))
    for i in range(3):
        X[i, :len(polys[i])] = _poly_float(polys[i])
    X *= scale
    p0 = X[:, dw].copy()  # lim X/w (w monic)
    F = -(X - np.outer(p0, wf)) / 2
    C = np.zeros((dw + 1, 8))
    C[:, 0] = wf
    C[:dw, 5:8] = F[:, :dw].T
    if np.max(np.abs(F)) == 0:
        raise InputError("the curve is a single point (x/w, y/w, z/w is constant)")
    return C, p0, wf, X


def curve_plane(F):
    """Unit normal of the plane of the curve, from the vector coefficients F (deg, 3) of its translation
    (None when the curve is not planar; for a straight segment, a normal of the segment)."""
    F = np.asarray(F, float)
    _, sv, Vt = np.linalg.svd(F, full_matrices=True)
    sv = np.concatenate([sv, np.zeros(3 - len(sv))])
    tol = 1e-9 * max(sv[0], 1e-300)
    if sv[2] > tol:
        return None
    if sv[1] > tol:
        return Vt[2]
    return perpendicular_basis(Vt[0])[0]


def _rotation_cofactor(w, p0, normal, sign):
    """H = prod over the quadratic factors (a, b) of w of (t - x), x = a + sign b n + eps (v x p0): coaxial
    rotations about the line through p0 with direction -sign n."""
    from synth.algebra.factorize import norm_quadratics
    from synth.algebra.polynomial import product_of_linear

    quads, mult, _ = norm_quadratics(np.asarray(w, float))
    hs = []
    for (c0, c1), k in zip(quads, mult):
        a = -c1 / 2
        b = np.sqrt(max(c0 - a * a, 0.0))
        v = sign * b * np.asarray(normal, float)
        for _ in range(k):
            hs.append(np.array([a, *v, 0.0, *np.cross(v, p0)]))
    return product_of_linear(np.array(hs)), len(hs)


def curve_motions(polys, *, scale: float = 1.0, method: str = "auto"):
    """Candidate coupler motions for the curve: list of dicts with keys method, motion (C'), result
    (CofactorResult), joints; and (p0, w, X)."""
    from synth.algebra.polynomial import poly_mul

    if method not in ("auto", "translation", "rotation"):
        raise InputError(f"unknown method {method!r} (auto, translation, rotation)")
    C, p0, w, X = curve_translation(polys, scale)
    out, errors = [], []
    if method in ("auto", "translation"):
        try:
            res = factorize_with_cofactor(C)
            out.append({"method": "translation", "motion": C, "result": res, "joints": joint_count(res.factors)})
        except SynthesisError as e:
            errors.append(f"translation: {e}")
    # auto tries both and keeps the smaller linkage (a repeated factor of w can still gain: a Viviani
    # quartic gives 19 joints by rotation and 25 by translation); a parallelogram (4 joints) is final
    try_rotation = method == "rotation" or (method == "auto" and not (out and out[0]["joints"] <= 4))
    if try_rotation:
        F = C[:-1, 5:8]
        n = curve_plane(F)
        dirs = [n] if n is not None else []
        if n is None:  # spatial curve: try the principal directions of its spread
            _, _, Vt = np.linalg.svd(F, full_matrices=True)
            dirs = list(Vt[::-1])
        for d in dirs:
            got = None
            for sign in (1.0, -1.0):
                H, _ = _rotation_cofactor(w, p0, d, sign)
                CH = poly_mul(C, H)
                try:
                    res = factorize_with_cofactor(CH)
                except SynthesisError as e:
                    errors.append(f"rotation: {e}")
                    continue
                cand = {"method": "rotation", "motion": CH, "result": res, "joints": joint_count(res.factors),
                        "H": H, "axis": {"point": p0, "direction": (-sign * np.asarray(d)).tolist()}}
                if got is None or cand["joints"] < got["joints"]:
                    got = cand
                if res.deg_R == 0:
                    break
            if got is not None:
                out.append(got)
                if got["result"].deg_R == 0:
                    break
    if not out:
        raise SynthesisError("no factorization of the curve's motion was found: " + "; ".join(errors))
    out.sort(key=lambda c: (c["joints"], c["method"] != "rotation"))
    return out, (p0, w, X)


def trace_error(linkage: Linkage, samples: int = CHECK_SAMPLES) -> float:
    """Largest distance between the tracer point and the curve point at the same parameter t."""
    from synth.checks import sample_parameters

    cur = linkage.info.synthesis.curve
    X = np.asarray(cur.xyz_coefficients_m, float)
    w = np.asarray(cur.w_coefficients, float)
    p0 = np.asarray(cur.p0_m, float)
    t = sample_parameters(linkage, samples)[:-1]
    disp = linkage.displacements(linkage.angles_at(t))[linkage.tool_link]
    traced = np.einsum("...ij,j->...i", disp[..., :3, :3], p0) + disp[..., :3, 3]
    pw = np.polyval(w[::-1], t)
    target = np.stack([np.polyval(X[i][::-1], t) for i in range(3)], -1) / pw[:, None]
    return float(np.max(np.linalg.norm(traced - target, axis=1)))


def curve_linkage(x, y, z, w, *, scale: float = 1.0, method: str = "auto", m0=None, seed: int = 0,
                  texts=None) -> Linkage:
    """The multi-loop linkage (kind "curve") with a frame ``tracer`` whose origin draws (x/w, y/w, z/w)
    (ascending coefficient lists, Fractions or floats; lengths times ``scale`` give metres) as the
    linkage runs through its cycle (parameter t over R and infinity)."""
    cands, (p0, wf, X) = curve_motions([x, y, z, w], scale=scale, method=method)
    best = cands[0]
    res: CofactorResult = best["result"]
    T = np.eye(4)
    T[:3, 3] = p0
    curve = CurveRecord(x=texts[0] if texts else poly_text(x), y=texts[1] if texts else poly_text(y),
                        z=texts[2] if texts else poly_text(z), w=texts[3] if texts else poly_text(w),
                        scale_to_m=scale, xyz_coefficients_m=X, w_coefficients=wf, p0_m=p0, tracer="tracer",
                        method=best["method"], axis=best.get("axis"),
                        alternatives=tuple(Alternative(method=c["method"], joints=c["joints"]) for c in cands))
    motion = CouplerMotion(coupler=best["motion"], cofactor=res.R, cofactor_text=poly_text(res.R), deg_R=res.deg_R,
                           mrpf_text=poly_text(res.g), factorization_residual=res.residual,
                           components=tuple(_plain_report(r) for r in res.report), rotation_cofactor_H=best.get("H"))
    info = MultiLoop(curve=curve, motion=motion)
    markers = {"tracer": Marker(link="coupler", position=tuple(p0.tolist()))}
    lk = _build(res.factors, best["motion"], "curve", info, T, markers=markers, m0=m0, seed=seed)
    lk.checks["max_trace_error"] = trace_error(lk)
    return lk


def spec_linkage(spec, *, scale: float = 1.0, method: str = "auto", m0=None) -> Linkage:
    """Dispatch a parsed CurveSpec / MotionSpec."""
    if isinstance(spec, CurveSpec):
        return curve_linkage(*spec.polys, scale=scale, method=method, m0=m0, texts=spec.texts)
    return motion_linkage(spec.C, scale=scale, m0=m0, text=spec.text)


__all__ = ["curve_linkage", "motion_linkage", "spec_linkage", "UnboundedCurveError", "UnboundedMotionError", "trace_error"]
