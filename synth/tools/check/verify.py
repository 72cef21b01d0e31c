"""`mpsynth check`: read an output directory back and verify the whole claim it makes (docs/conventions.md).

Nothing here trusts the synthesis code: OUT is read by the one reader of output directories
(`synth.io.readback.read_files`: the URDF into our own small model, `synth.io.urdfmodel`, forward
kinematics by 4x4 products; linkage.json as plain JSON), meshes are loaded with trimesh from the files,
the independent continuation is `synth.tools.check.continuation`. The checks, each adding one line per problem:

1. structure: one root ``base``, unique names, one parent per link, no cycle, joints name existing
   links, the ``<gazebo><joint type="fixed">`` welds (named ``loop_closure``, ``loop_closure_2``, ...)
   equal linkage.json's ``closures``, link ``tool`` on the tool link by a fixed joint when the output
   has poses, every joint of linkage.json is a revolute URDF joint with the same parent and child, and
   its world axis at all-zero angles is linkage.json's Plücker line;
2. meshes: every referenced mesh is a relative path (``package://NAME/...`` is resolved inside OUT),
   exists, is a binary STL that loads, is watertight with positive volume, and its size (after the
   URDF ``scale``) fits the linkage's size;
3. poses: at every pose's ``joint_angles`` the URDF's ``tool`` frame equals the pose matrix of
   linkage.json and, with ``poses``, the pose of the POSES file; every loop is closed there;
4. cycle, exact: the angle laws ``theta_j(t) = 2 atan2(b_j, t - a_j)`` (``joints[].angle_law``; for a planar
   four-bar's joints with ``angle_law.fourbar`` the loop law of that angle, docs/fourbar.md) give the
   pose angles at ``poses[].t``; sampled uniformly in the first joint's angle over a full turn they keep
   every loop closed, and the coupler follows ``motion_polynomial``;
5. cycle, independent: the first joint of the first branch is driven through a full turn in adaptive
   steps (tangent predictor, Gauss-Newton corrector on all loops together, step halved on failure and
   grown on success); it must complete the turn, come back to all-zero, and agree with the angle laws
   (both within the continuation's tolerance below). The laws guide it only at branch crossings: where
   it leaves them next to a configuration of the laws whose loop Jacobian loses rank, it re-seeds on the
   laws' configuration when that closes the loops (`synth.tools.check.continuation.continue_loop`, ``guide``),
   and the crossing is reported (``branch_crossings_deg``; docs/exceptional.md, section 6).

Tolerances: with L the linkage's size (RMS spread of joint feet and tool positions) and A the largest
coordinate, lengths must agree to ``rtol * L + 1e-13 * A`` and angles to ``rtol + 1e-13 * A / L``
(``rtol`` 1e-8 by default); the continuation must agree with the angle laws to ``max(1e-6, 100 * angle
tolerance)`` rad, times rho / 1e3 where the laws' transmission ratio rho (the largest speed ratio of two
joints, `synth.synthesis.conditioning`) exceeds 1e3. Figures of every measurement are returned for
``--json``.
"""
from __future__ import annotations

import math

import numpy as np

from synth.algebra.anglelaw import angle_law, angle_law_inverse
from synth.algebra.polynomial import pose_at
from synth.tools.check.continuation import continue_loop, crossing, law_angles
from synth.algebra.geometry import invert_pose, pose_difference
from synth.frames import TWO_PI, wrap_angle
from synth.io.posespec import describe_value
from synth.io.linkagedoc import angle_laws, angle_rates, is_number, loop_laws
from synth.io.readback import OutputFiles, read_files, solution_dirs
from synth.tools.check.meshes import MeshChecks
from synth.tools.check.structure import StructureChecks, matrix_or_none
from synth.synthesis.conditioning import transmission_ratio
from synth.task import default_name


# ----------------------------------------------------------------------------- checker
class _Checker(StructureChecks, MeshChecks):
    def __init__(self, output: OutputFiles, poses=None, rtol: float = 1e-8, steps: int = 360,
                 samples: int = 720, meshes: bool = True):
        self.o = output
        self.u = output.urdf
        self.doc = output.doc
        self.poses_file = poses
        self.rtol = rtol
        self.steps = steps
        self.samples = samples
        self.do_meshes = meshes
        self.problems: list[str] = list(self.u.problems)
        self.figures: dict = {}

    def fail(self, msg: str) -> None:
        self.problems.append(msg)

    # -------------------------------------------------------------- json helpers
    def _json_joints(self) -> list[dict]:
        js = self.doc.get("joints")
        if not isinstance(js, list):
            return []
        return [j for j in js if isinstance(j, dict) and isinstance(j.get("name"), str)]

    def _json_poses(self) -> list[dict]:
        ps = self.doc.get("poses")
        return [p for p in ps if isinstance(p, dict)] if isinstance(ps, list) else []

    def _angle_laws(self) -> dict[str, tuple[float, float]]:
        return angle_laws(self.doc)

    def _angle_rates(self) -> dict[str, int]:
        return angle_rates(self.doc)

    def _loops(self) -> dict:
        return loop_laws(self.doc)

    # -------------------------------------------------------------- scales
    def _scales(self):
        F0 = self.u.fk({})
        pts = [F0[j.child][:3, 3] for j in self.u.joints.values() if j.kind != "fixed"]
        for p in self._json_poses():
            M = matrix_or_none(p.get("matrix"))
            if M is not None:
                pts.append(M[:3, 3])
        if "tool" in F0:
            pts.append(F0["tool"][:3, 3])
        pts = np.array(pts) if pts else np.zeros((1, 3))
        c = pts.mean(axis=0)
        L = float(max(np.sqrt(np.mean(np.sum((pts - c) ** 2, axis=1))), 1e-12))
        A = float(max(np.abs(pts).max(), L))
        self.L, self.A = L, A
        self.tol_len = self.rtol * L + 1e-13 * A
        self.tol_ang = self.rtol + 1e-13 * A / L
        self.figures["length_scale"] = L
        self.figures["tolerance"] = {"length": self.tol_len, "angle": self.tol_ang}

    # -------------------------------------------------------------- 3. poses
    def poses(self):
        u = self.u
        recs = self._json_poses()
        self.figures["poses"] = len(recs)
        if not recs and not self.poses_file:
            return
        if not recs:
            self.fail("linkage.json: no poses")
        moving = [jn for jn, j in u.joints.items() if j.kind != "fixed"]
        ref = self._closure_refs()
        file_T = None
        if self.poses_file is not None:
            file_T = self.poses_file.matrices
            if len(file_T) != len(recs):
                self.fail(f"{self.poses_file.source}: {len(file_T)} poses, linkage.json has {len(recs)}")
        pt = pr = ft = fr = ct = cr = 0.0
        for i, rec in enumerate(recs):
            name = rec.get("name", default_name(i))
            ang = rec.get("joint_angles")
            if not isinstance(ang, dict):
                self.fail(f"linkage.json: pose {i} ({name}) has no joint_angles")
                continue
            missing = [jn for jn in moving if jn not in ang]
            if missing:
                self.fail(f"linkage.json: pose {i} ({name}) lacks angles for {', '.join(missing)}")
            cfg = {k: float(v) for k, v in ang.items() if isinstance(v, (int, float))}
            F = u.fk(cfg)
            M = matrix_or_none(rec.get("matrix"))
            if "tool" in F:
                if M is None:
                    self.fail(f"linkage.json: pose {i} ({name}) has no 4x4 matrix")
                else:
                    dt, dr = pose_difference(F["tool"], M)
                    pt, pr = max(pt, dt), max(pr, dr)
                    if dt > self.tol_len or dr > self.tol_ang:
                        self.fail(f"tool frame misses pose {i} ({name}) of linkage.json by {dt:.3g} m, {dr:.3g} rad")
                if file_T is not None and i < len(file_T):
                    dt, dr = pose_difference(F["tool"], file_T[i])
                    if self.poses_file.is_point[i]:  # a point task prescribes the position only
                        dr = 0.0
                    ft, fr = max(ft, dt), max(fr, dr)
                    if dt > self.tol_len or dr > self.tol_ang:
                        names = getattr(self.poses_file, "names", None) or []
                        fname = names[i] if i < len(names) else default_name(i)
                        self.fail(f"tool frame misses pose {i} ({fname}) of {self.poses_file.source} "
                                  f"by {dt:.3g} m, {dr:.3g} rad"
                                  + (f" (linkage.json calls pose {i} {name})" if fname != name else ""))
            for (a, b), R in zip(self.closures, ref):
                dt, dr = pose_difference(F[a] @ R, F[b])
                ct, cr = max(ct, dt), max(cr, dr)
                if dt > self.tol_len or dr > self.tol_ang:
                    self.fail(f"loop {a}-{b} open at pose {i} ({name}) by {dt:.3g} m, {dr:.3g} rad")
        self.figures["pose_error"] = {"translation": pt, "rotation": pr}
        if file_T is not None:
            self.figures["pose_file_error"] = {"translation": ft, "rotation": fr}
        self.figures["closure_at_poses"] = {"translation": ct, "rotation": cr}

    def _closure_refs(self):
        F0 = self.u.fk({})
        return [invert_pose(F0[a]) @ F0[b] for a, b in self.closures]

    # -------------------------------------------------------------- 4. exact cycle from the angle laws
    def laws(self):
        laws = self._angle_laws()
        moving = [jn for jn in self.loop_joints]
        if not laws:
            self.figures["angle_laws"] = "absent"
            return
        missing = [jn for jn in moving if jn not in laws]
        if missing:
            self.fail(f"linkage.json: no angle law for joint(s) {', '.join(missing)}")
            return
        for jn, (a, b) in laws.items():
            if not (math.isfinite(a) and math.isfinite(b)) or b == 0:
                self.fail(f"linkage.json: joint {jn} has angle law a={a}, b={b} (b must be finite and non-zero)")
                return
        rates = self._angle_rates()
        # pose angles from the laws
        worst = 0.0
        for i, rec in enumerate(self._json_poses()):
            if "t" not in rec or not isinstance(rec.get("joint_angles"), dict):
                continue
            t = rec["t"]
            if t is not None and not is_number(t):
                self.fail(f"linkage.json: pose {i}: t is {describe_value(t)}, not a number")
                return
            t = math.inf if t is None else float(t)
            for jn, v in rec["joint_angles"].items():
                if not is_number(v):
                    self.fail(f"linkage.json: pose {i}: joint angle {jn} is {describe_value(v)}, not a finite number")
                    return
                if jn in laws:
                    a, b = laws[jn]
                    th = float(angle_law(a, b, t, rates.get(jn, 1)))
                    if jn in self._loops():  # a four-bar's loop law of the crank's angle (docs/fourbar.md)
                        th = float(self._loops()[jn].angle(th))
                    worst = max(worst, abs(float(wrap_angle(th - float(v)))))
        if worst > self.tol_ang:
            self.fail(f"linkage.json: pose joint angles differ from the angle laws by {worst:.3g} rad")
        self.figures["law_vs_pose_angles"] = worst
        # loops along the motion, uniform in the driver's angle
        phi = np.linspace(0.0, TWO_PI, self.samples, endpoint=False)
        cfg = law_angles(laws, self.driver, phi, rates, self._loops())
        F = self.u.fk(cfg, n=len(phi))
        ct = cr = 0.0
        for (a, b), R in zip(self.closures, self._closure_refs()):
            dt, dr = pose_difference(F[a] @ R, F[b])
            ct, cr = max(ct, float(dt.max())), max(cr, float(dr.max()))
        self.figures["law_closure_error"] = {"translation": ct, "rotation": cr, "samples": len(phi)}
        if ct > self.tol_len or cr > self.tol_ang:
            self.fail(f"loop open along the angle laws' motion by {ct:.3g} m, {cr:.3g} rad")
        # the coupler follows the motion polynomial (when it is given)
        C = self.doc.get("motion_polynomial")
        tool_link = self.doc.get("tool_link", "coupler")
        if isinstance(C, list) and C and tool_link in F:
            try:
                Cn = np.array(C, float)
                a, b = laws[self.driver]
                t = angle_law_inverse(a, b, phi, rates.get(self.driver, 1))
                target = pose_at(Cn, t)
                disp = F[tool_link] @ invert_pose(self.u.fk({})[tool_link])
                dt, dr = pose_difference(disp, target)
                me = {"translation": float(dt.max()), "rotation": float(dr.max())}
            except Exception as e:  # noqa: BLE001
                self.fail(f"linkage.json: motion_polynomial cannot be evaluated ({type(e).__name__}: {e})")
                me = None
            if me is not None:
                self.figures["motion_polynomial_error"] = me
                if me["translation"] > 10 * self.tol_len or me["rotation"] > 10 * self.tol_ang:
                    self.fail(f"coupler leaves the motion polynomial by {me['translation']:.3g} m, "
                              f"{me['rotation']:.3g} rad")

    # -------------------------------------------------------------- 5. independent continuation
    def continuation(self):
        if not self.closures or self.driver is None:
            return
        others = [jn for jn in self.loop_joints if jn != self.driver]
        rho = self._transmission()
        # where a joint turns rho times faster than the driver, its continued angle is rho times as
        # sensitive to the loop residual: the tolerance grows with the laws' transmission ratio
        tol_dev = max(1e-6, 100 * self.tol_ang) * max(1.0, rho / 1e3)
        laws = self._angle_laws()
        guide = None
        if laws and others and all(jn in laws for jn in self.loop_joints):
            rates = self._angle_rates()

            def guide(p):
                ex = law_angles(laws, self.driver, np.array([p]), rates, self._loops())
                return np.array([ex[jn][0] for jn in others])
        result = continue_loop(self.u, self.closures, self.driver, others, steps=self.steps,
                               length=self.L, tol=max(self.tol_ang, self.tol_len / self.L), ratio=rho,
                               guide=guide, guide_tol=tol_dev)
        dev, crossings = None, []
        if laws and all(jn in laws for jn in self.loop_joints) and len(result["path"]):
            path = np.array(result["path"])
            exact = law_angles(laws, self.driver, path[:, 0], self._angle_rates(), self._loops())
            ex = np.stack([exact[jn] for jn in others], axis=1) if others else np.zeros((len(path), 0))
            devs = np.abs(wrap_angle(path[:, 1:] - ex)).max(axis=1, initial=0.0)
            # a point off the laws next to a singular configuration of the laws (the loop Jacobian loses
            # rank) whose polished configuration closes the loops is on another branch of the
            # configuration curve crossing the motion there (docs/exceptional.md, section 6): a branch
            # crossing passed, not an error, when the continuation comes back to the motion after it
            for i in np.flatnonzero(devs > tol_dev)[:16]:
                c = crossing(self.u, self.closures, self.driver, others, float(path[i, 0]), path[i, 1:], ex[i],
                             length=self.L)
                if c["residual"] <= 1e-3 * self.tol_ang and c["conditioning"] <= 1e-3 and c["deviation"] <= 1e-2:
                    devs[i] = 0.0
                    crossings.append(float(path[i, 0]))
            dev = float(devs.max(initial=0.0))
        fig = {"driver": self.driver, "followed": result["followed"], "steps": result["accepted"],
               "rejected": result["rejected"], "max_residual": result["max_residual"]}
        if dev is not None:
            fig["max_deviation_from_laws"] = dev
        crossings += [c["angle"] for c in result.get("crossings", [])]
        if crossings:  # one angle per crossing (points within a degree of each other are one)
            merged = []
            for p in sorted(crossings):
                if not merged or p - merged[-1] > math.radians(1.0):
                    merged.append(p)
            fig["branch_crossings_deg"] = [round(math.degrees(p), 3) for p in merged]
        self.figures["continuation"] = fig
        if result["followed"] < 1.0:
            self.fail(f"linkage driven by {self.driver} stuck at {math.degrees(result['angle']):.4g} deg of a "
                      f"full turn (loop residual {result['stuck_residual']:.3g})")
        else:
            back = float(np.abs(wrap_angle(np.array(result["path"][-1][1:]))).max()) if others else 0.0
            fig["return_error"] = back
            if back > tol_dev:
                self.fail(f"after a full turn of {self.driver} the linkage is not back at all-zero (off by {back:.3g} rad)")
        if dev is not None and dev > tol_dev:
            self.fail(f"continuation driven by {self.driver} deviates from the angle laws by {dev:.3g} rad")

    def _transmission(self) -> float:
        """The largest speed ratio of two loop joints (`synth.synthesis.conditioning`) from the laws."""
        laws = self._angle_laws()
        ab = np.array([laws[jn] for jn in self.loop_joints if jn in laws], float).reshape(-1, 2)
        rho = float(transmission_ratio(ab[:, 0], ab[:, 1])) if len(ab) else 1.0
        self.figures["transmission_ratio"] = rho
        return rho if math.isfinite(rho) else 1.0  # broken laws (b = 0) are reported by `laws`

    # -------------------------------------------------------------- run
    def run(self):
        if self.u.problems:  # a URDF that cannot be posed (a zero axis, a broken tree): nothing more to judge
            return self.problems, self.figures
        self._scales()
        self.structure()
        # joints in the loops (those that move some closure pair relative to each other), driver
        loop = []
        for a, b in self.closures:
            pa, pb = self.u.path(a), self.u.path(b)
            loop += [j for j in pa + pb if (j in pa) != (j in pb)]
        self.loop_joints = [j for j in dict.fromkeys(loop) if self.u.joints[j].kind in ("revolute", "continuous")]
        self.driver = None
        if self.closures:
            first = [j for j in self.u.path(self.closures[0][0]) if j in self.loop_joints]
            br = self.doc.get("branches")
            if isinstance(br, list) and br and isinstance(br[0], list) and br[0] and br[0][0] in self.loop_joints:
                self.driver = br[0][0]
            elif first:
                self.driver = first[0]
        if self.do_meshes:
            self.meshes()
        self.poses()
        if self.closures and self.driver:
            self.laws()
            self.continuation()
        return self.problems, self.figures


def check_output(out, poses=None, *, rtol: float = 1e-8, steps: int = 360, samples: int = 720,
                 meshes: bool = True) -> dict:
    """Check one output directory; returns ``{"ok", "problems", "figures"}``. ``poses`` is an optional
    `synth.io.poses.PoseSet` to compare the tool frame with. Raises InputError when OUT is unreadable."""
    output = read_files(out)
    problems, figures = _Checker(output, poses, rtol, steps, samples, meshes).run()
    return {"ok": not problems, "problems": problems, "figures": figures}


def check_tree(out, poses=None, **kw) -> dict:
    """`check_output` on OUT or, for a multi-solution OUT, on each solution directory (problems are then
    prefixed with the solution id, figures keyed by it)."""
    dirs = solution_dirs(out)
    if len(dirs) == 1 and dirs[0][0] == "":
        return check_output(dirs[0][1], poses, **kw)
    problems, figures = [], {}
    for sid, d in dirs:
        r = check_output(d, poses, **kw)
        problems += [f"{sid}: {p}" for p in r["problems"]]
        figures[sid] = r["figures"]
    return {"ok": not problems, "problems": problems, "figures": figures}
