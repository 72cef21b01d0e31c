"""linkage.step (synth/io/step.py, `mpsynth export OUT --step`): one named B-rep solid per STL, with the
STL's volume; nothing imported or written without the cad extra."""
from __future__ import annotations

import contextlib
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

sys.path.insert(0, str(Path(__file__).resolve().parent))
from conftest import REPO  # noqa: E402

import synth  # noqa: E402
from synth.design.choose import design_for  # noqa: E402
from synth.io import step as step_mod  # noqa: E402
from synth.io.meshes import Primitive, pin_ends  # noqa: E402
from synth.io.names import MESH_UNIT_SCALE  # noqa: E402
from synth.io.poses import load_poses  # noqa: E402
from synth.io.solid import read_stl_triangles, signed_volume  # noqa: E402
from synth.io.writer import write_output  # noqa: E402


def _kernel():
    """gmsh, or a skip without the cad extra (or without the libraries its wheel loads)."""
    return step_mod.load_kernel() or pytest.skip("no gmsh (pip install 'mpsynth[cad]')")


def _write(tmp_path, fixture, kind):
    lk = getattr(synth, kind)(load_poses(str(REPO / "fixtures" / fixture)).matrices)
    out = tmp_path / kind
    write_output(lk, out, robot_name=kind, result=design_for(lk))
    return out


def _step_solids(path: Path) -> dict[str, float]:
    """{part name: volume mm^3} of a STEP file as gmsh's OpenCASCADE reads it back."""
    gmsh = _kernel()
    gmsh.initialize(readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.open(str(path))
        return {gmsh.model.getEntityName(3, t).rsplit("/", 1)[-1]: gmsh.model.occ.getMass(3, t)
                for _, t in gmsh.model.getEntities(3)}
    finally:
        gmsh.finalize()


def _stl_volumes(out: Path) -> dict[str, float]:
    return {f.stem: signed_volume(read_stl_triangles(f.read_bytes()).astype(float))
            for f in (out / "meshes").glob("*.stl")}


@pytest.mark.parametrize("fixture,kind", [("bennett_mm_deg.yaml", "bennett"), ("sixbar_example.yaml", "sixbar"),
                                          ("sixbar_points.yaml", "sixbar")])
def test_step_holds_one_named_solid_per_stl_with_its_volume(tmp_path, fixture, kind):
    """The shipped fixtures' outputs as the commands write them (for the 6R: its choice among candidates)."""
    _kernel()
    out = tmp_path / kind
    from cli.main import mpsynth as cli_main

    r = CliRunner().invoke(cli_main, [kind, str(REPO / "fixtures" / fixture), "-o", str(out), "-q"])
    assert r.exit_code == 0, r.output
    text = (out / "linkage.step").read_text()
    stl = _stl_volumes(out)
    assert len(re.findall(r"MANIFOLD_SOLID_BREP\(", text)) == len(stl)  # the file itself, not gmsh's reading
    assert "Open CASCADE STEP translator" not in text
    assert "SI_UNIT(.MILLI.,.METRE.)" in text  # built in metres, written in mm (synth/io/step.py)
    # mm, per part: OpenCASCADE's confusion tolerance 1e-7 m, raised by its booleans where faces nearly touch
    # (measured 0.1 mm on sixbar_example's base and 0.5 mm on sixbar_points' link_h1, which read back with 5 %
    # of its volume, before such parts were built again): at most a quarter of the bores' clearance
    accuracy = step_mod.part_accuracies(text)
    assert set(accuracy) == set(stl) and max(accuracy.values()) <= 0.25 * 0.2
    solids = _step_solids(out / "linkage.step")
    assert set(solids) == set(stl)
    for name, v in stl.items():
        assert solids[name] == pytest.approx(v, rel=0.03), name  # facets vs exact cylinders and spheres
        assert solids[name] > v  # the facets lie inside the true surfaces: the STL is the smaller


def test_step_is_in_millimetres_at_the_home_configuration(tmp_path):
    """A pin's solid spans its axis from the design's start to end offsets, in mm, in world coordinates
    (no wider than its head)."""
    gmsh = _kernel()
    lk = synth.bennett(load_poses(str(REPO / "fixtures/bennett_mm_deg.yaml")).matrices)
    design = design_for(lk).design
    path = tmp_path / "x.step"
    path.write_text(step_mod.step_text(lk, design))
    pin = design.pins[0]
    j = lk.joint(pin.joint)
    ends = [(lk.joint_sites()[pin.joint] + s * j.direction) / MESH_UNIT_SCALE for s in (pin.start, pin.end)]
    gmsh.initialize(readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.open(str(path))
        tag = next(t for _, t in gmsh.model.getEntities(3) if gmsh.model.getEntityName(3, t).endswith(f"pin_{pin.joint}"))
        box = np.array(gmsh.model.getBoundingBox(3, tag)).reshape(2, 3)
    finally:
        gmsh.finalize()
    r = design.pin_radius / MESH_UNIT_SCALE
    head = pin_ends(lk, design, pin.joint).head / MESH_UNIT_SCALE  # the widest part
    lo, hi = np.minimum(*ends), np.maximum(*ends)
    assert np.all(box[0] >= lo - head - 1e-3 * r) and np.all(box[1] <= hi + head + 1e-3 * r)
    assert np.all(box[0] <= lo + 1e-3 * r) and np.all(box[1] >= hi - 1e-3 * r)  # it spans its axis segment


def test_export_step_writes_it_for_an_existing_output(tmp_path):
    _kernel()
    from cli.main import mpsynth as cli

    out = _write(tmp_path, "bennett_mm_deg.yaml", "bennett")
    first = (out / "linkage.step").read_text()
    (out / "linkage.step").unlink()
    r = CliRunner().invoke(cli, ["export", str(out), "--step", "--json"])
    assert r.exit_code == 0, r.output
    again = (out / "linkage.step").read_text()
    assert again == first  # reproducible: no clock, no count of earlier files in the header or the data
    assert "linkage.step" in (out / ".mpsynth-output").read_text()


def test_the_summary_names_linkage_step_or_warns_that_it_is_missing(tmp_path, monkeypatch):
    _kernel()
    from cli.main import mpsynth as cli

    fixture = str(REPO / "fixtures/bennett_mm_deg.yaml")
    r = CliRunner().invoke(cli, ["bennett", fixture, "-o", str(tmp_path / "a")])
    assert r.exit_code == 0 and "linkage.json, linkage.step, 4 link meshes" in r.output
    assert "no linkage.step" not in r.output

    def failing(*args, **kwargs):
        raise RuntimeError("a boolean failed")

    monkeypatch.setattr(step_mod, "step_text", failing)
    r = CliRunner().invoke(cli, ["bennett", fixture, "-o", str(tmp_path / "b")])
    assert r.exit_code == 0 and not (tmp_path / "b" / "linkage.step").exists()
    assert "linkage.json, 4 link meshes" in r.output
    assert "warning: no linkage.step: OpenCASCADE could not build every part" in r.output


def test_without_the_extra_nothing_is_written_and_export_says_why(tmp_path, monkeypatch):
    from cli.main import mpsynth as cli

    out = tmp_path / "b"
    monkeypatch.setattr(step_mod, "have_kernel", lambda: False)
    import synth.tools.cadexport as cadexport

    monkeypatch.setattr(cadexport, "have_kernel", lambda: False)
    lk = synth.bennett(load_poses(str(REPO / "fixtures/bennett_mm_deg.yaml")).matrices)
    write_output(lk, out, robot_name="b", result=design_for(lk))
    assert not (out / "linkage.step").exists() and (out / "linkage.urdf").exists()
    r = CliRunner().invoke(cli, ["export", str(out), "--step"])
    assert r.exit_code == 2 and "mpsynth[cad]" in r.output


def test_cli_and_writing_without_step_do_not_import_gmsh():
    code = ("import sys, cli.main, synth.io.export, synth.tools.cadexport; "
            "assert 'gmsh' not in sys.modules, 'gmsh imported'")
    subprocess.run([sys.executable, "-c", code], check=True, cwd=REPO)


def test_products_are_renamed_in_order_or_refused():
    text = ("#7 = PRODUCT('Open CASCADE STEP translator 7.8 3',\n  'Open CASCADE STEP translator 7.8 3','',(#8));\n"
            "#9 = PRODUCT('Open CASCADE STEP translator 7.8 3.2',\n  'Open CASCADE STEP translator 7.8 3.2','',(#8));\n"
            "#10 = PRODUCT('Open CASCADE STEP translator 7.8 3.1',\n  'Open CASCADE STEP translator 7.8 3.1','',(#8));\n")
    named = step_mod.name_products(text, ["base", "pin_h1"])
    assert "PRODUCT('linkage','linkage'" in named
    assert named.index("'pin_h1'") < named.index("'base'")  # by the translator's number, not file order
    with pytest.raises(ValueError):
        step_mod.name_products(text, ["base", "pin_h1", "coupler"])


@contextlib.contextmanager
def _occ_model(name: str):
    """gmsh initialised with an empty model ``name``: yields its OpenCASCADE kernel (finalised after)."""
    gmsh = _kernel()
    gmsh.initialize(readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add(name)
        yield gmsh.model.occ
    finally:
        gmsh.finalize()


def _cyl(a, b, r):
    return Primitive("cylinder", np.asarray(a, float), np.asarray(b, float), r)


def test_a_pin_is_its_profile_revolved_with_the_fused_volume():
    """Coaxial cylinders (shaft, head) make one profile: axial position and radius corners, from the axis
    round to the axis; a gap, an end off the axis or another kind of primitive makes none."""
    shaft, head = _cyl([0, 0, 0], [0, 0, 10], 1.0), _cyl([0, 0, 11], [0, 0, 8], 2.0)  # head reversed
    o, d, prof = step_mod.coaxial_profile([shaft, head])
    np.testing.assert_allclose(o, 0, atol=0)
    np.testing.assert_allclose(d, [0, 0, 1])
    np.testing.assert_allclose(prof, [[0, 0], [0, 1], [8, 1], [8, 2], [11, 2], [11, 0]], atol=1e-12)
    assert step_mod.coaxial_profile([shaft, _cyl([0, 0, 12], [0, 0, 13], 2.0)]) is None  # a gap
    assert step_mod.coaxial_profile([shaft, _cyl([0, 1e-3, 8], [0, 1e-3, 11], 2.0)]) is None  # off the axis
    assert step_mod.coaxial_profile([Primitive("capsule", shaft.p0, shaft.p1, 1.0), head]) is None
    with _occ_model("pin") as occ:
        tags = step_mod._occ_solids(occ, [shaft, head], [], 1.0)
        assert len(tags) == 1 and occ.getMass(3, tags[0]) == pytest.approx(np.pi * (8 + 4 * 3), rel=1e-9)
        occ.synchronize()
        model = step_mod.load_kernel().model
        assert {model.getType(2, t) for _, t in model.getEntities(2)} <= {"Cylinder", "Plane"}


def test_a_solid_in_more_pieces_than_the_mesh_is_refused():
    """`_checked_solids` keeps a B-rep part only with the STL's volume in the STL's number of bodies: two
    disjoint cylinders are two solids (accepted for 2 bodies, refused for 1)."""
    prims = [_cyl([0, 0, 0], [1, 0, 0], 0.1), _cyl([0, 0, 1], [1, 0, 1], 0.1)]  # parallel, 1 apart
    volume = 2 * np.pi * 0.01
    with _occ_model("two") as occ:
        assert len(step_mod._checked_solids(occ, prims, [], 1.0, volume, 2)[0]) == 2
        with pytest.raises(RuntimeError, match="in 2 solids, not the mesh"):
            step_mod._checked_solids(occ, prims, [], 1.0, volume, 1)


@pytest.mark.parametrize("revolved", [True, False])
def test_one_boolean_at_a_time_builds_the_same_link(revolved):
    """The fallback of `_checked_solids` (a fuse per primitive, a cut per bore) gives the batch's solid: a
    hub with a bar ending in it, minus the bore, is one solid with the same volume either way."""
    prims = [_cyl([0, 0, -1], [0, 0, 1], 1.0), Primitive("capsule", np.zeros(3), np.array([5.0, 0, 0]), 0.8)]
    bores = [_cyl([0, 0, -1.5], [0, 0, 1.5], 0.4)]
    with _occ_model("link") as occ:
        batch, single = (step_mod._occ_solids(occ, prims, bores, 1.0, revolved, k) for k in (False, True))
        assert len(batch) == len(single) == 1
        assert occ.getMass(3, single[0]) == pytest.approx(occ.getMass(3, batch[0]), rel=1e-9)
        assert 2 * np.pi < occ.getMass(3, batch[0]) < 2 * np.pi + np.pi * 0.64 * 5  # the hub, plus part of the bar


def test_parts_are_placed_by_their_assembly_occurrence():
    """`place_products` follows occurrence k to its ITEM_DEFINED_TRANSFORMATION's target placement (line
    breaks anywhere the translator puts them) and writes the part's origin there, round-tripping."""
    text = ("#10 = SHAPE_REPRESENTATION('',(#11,#15,#19),#47);\n"
            "#11 = AXIS2_PLACEMENT_3D('',#12,#13,#14);\n#12 = CARTESIAN_POINT('',(0.,0.,0.));\n"
            "#15 = AXIS2_PLACEMENT_3D('',#16,#17,#18);\n#16 = CARTESIAN_POINT('',(0.,0.,0.));\n"
            "#19 = AXIS2_PLACEMENT_3D('',#20,#21,#22);\n#20 = CARTESIAN_POINT('',(0.,0.,0.));\n")
    for k, (first, target) in enumerate(((100, 19), (200, 15)), 1):  # occurrence 1 at #19, 2 at #15
        text += (f"#{first} = CONTEXT_DEPENDENT_SHAPE_REPRESENTATION(#{first + 1},#{first + 3});\n"
                 f"#{first + 1} = ( REPRESENTATION_RELATIONSHIP('','',#60,#10) \n"
                 f"REPRESENTATION_RELATIONSHIP_WITH_TRANSFORMATION(#{first + 2}) \nSHAPE_REPRESENTATION_RELATIONSHIP() );\n"
                 f"#{first + 2} = ITEM_DEFINED_TRANSFORMATION('','',#11,#{target});\n"
                 f"#{first + 3} = PRODUCT_DEFINITION_SHAPE('Placement','Placement of an item',#{first + 4}\n  );\n"
                 f"#{first + 4} = NEXT_ASSEMBLY_USAGE_OCCURRENCE('{k}','','',#5,#55,$);\n")
    far = (999999998.9154595, -2e9, 1e-300)
    out = step_mod.place_products(text, [far, (1.5, -0.0, 3.0)])
    point = re.search(r"#20 = CARTESIAN_POINT\('',\((.*)\)\);", out).group(1)
    assert tuple(float(x) for x in point.split(",")) == far
    assert "#16 = CARTESIAN_POINT('',(1.5,0.0,3.0));" in out
    assert "#12 = CARTESIAN_POINT('',(0.,0.,0.));" in out  # the assembly's own placement stays
    with pytest.raises(ValueError):
        step_mod.place_products(text, [far, far, far])  # no third occurrence


def test_model_unit_keeps_bars_above_a_thousandth_of_a_unit():
    class D:
        bar_radius = 0.0

    for r, unit in ((0.01, "M"), (1e-3, "M"), (5.7e-5, "MM"), (1e-7, "UM"), (1e-12, "UM")):
        D.bar_radius = r
        assert step_mod.model_unit(D)[0] == unit


def test_linkage_json_says_whether_linkage_step_was_written(tmp_path, monkeypatch):
    import json

    _kernel()
    from synth.tools.cadexport import export_step

    out = _write(tmp_path, "bennett_mm_deg.yaml", "bennett")
    assert (out / "linkage.step").exists() and json.loads((out / "linkage.json").read_text())["step"] is True
    monkeypatch.setattr(step_mod, "step_text", lambda *a, **k: (_ for _ in ()).throw(RuntimeError("failed")))
    lk = synth.bennett(load_poses(str(REPO / "fixtures/bennett_mm_deg.yaml")).matrices)
    write_output(lk, tmp_path / "b", robot_name="b", result=design_for(lk))
    assert json.loads((tmp_path / "b" / "linkage.json").read_text())["step"] is False
    monkeypatch.undo()
    export_step(tmp_path / "b")  # adds the file, and says so
    assert (tmp_path / "b" / "linkage.step").exists()
    assert json.loads((tmp_path / "b" / "linkage.json").read_text())["step"] is True


def test_coaxial_bores_are_cut_as_one_solid_of_revolution():
    """`coaxial_groups`: bores on one axis line that leave no gap are one run (its `coaxial_profile`), others
    stay alone; the union is unchanged."""
    a, b = _cyl([0, 0, -2], [0, 0, 2], 1.0), _cyl([0, 0, 1.9], [0, 0, 9], 1.0)  # overlap 0.1 on one axis
    head, far = _cyl([0, 0, -1], [0, 0, -4], 1.5), _cyl([3, 0, 0], [3, 0, 1], 1.0)
    runs = step_mod.coaxial_groups([a, far, b, head])
    assert [r[0] is x for r, x in zip(runs, (a, far))] == [True, True] and len(runs) == 2
    np.testing.assert_allclose(runs[0][1][2], [[-2, 0], [-2, 1.5], [1, 1.5], [1, 1], [11, 1], [11, 0]], atol=1e-12)  # from a.p0
    assert runs[1][1] is None


def test_a_link_whose_bore_continues_along_its_pin_is_one_solid():
    """sixbar_points' link_h1 (metres, as written: its first joint at the origin): a round bar 23 mm thick
    leaving its hub at 46 deg to the axis, a bore, its continuation along the pin overlapping it by 0.2 mm,
    the head's counterbore, and the far joint's hub and two coaxial bores. Cut as separate cylinders,
    OpenCASCADE left it in 2 to 8 pieces or lost volume in every construction; the coaxial runs give one
    solid with the mesh's volume."""
    from synth.io.meshes import _solid, primitive_solid

    rows = [("capsule", [0, 0, 0], [0.493354293483541, 0.5048512471134005, 0.2678014738529836], 0.023032473116945774),
            ("cylinder", [0.0010032445923888553, 0.00964426022700784, 0.015035627141620656],
             [-0.0010032445923888553, -0.00964426022700784, -0.015035627141620656], 0.01809101278799618),
            ("cylinder", [0.47553170394264355, 0.5039460777818275, 0.26907595771640247],
             [0.5111768830244384, 0.5057564164449734, 0.2665269899895647], 0.01809101278799618)]
    holes = [([0.001314613852841302, 0.012637474640797024, 0.019702118383180783],
              [-0.001314613852841302, -0.012637474640797024, -0.019702118383180783], 0.012127341858664119),
             ([0.006953677985469028, 0.06684619138289405, 0.10421477498668014],
              [0.001301467714312889, 0.012511099894389052, 0.01950509719934898], 0.012127341858664119),
             ([-0.0004904072285593312, -0.004714318886254944, -0.0073497333472948845],
              [-0.002317858445230159, -0.022281734867804895, -0.03473774552480144], 0.014712810230396943),
             ([0.47000024474834784, 0.5036651473811113, 0.26947150941039805],
              [0.5167083422187341, 0.5060373468456896, 0.2661314382955691], 0.011877341858664119),
             ([0.3390139986203243, 0.4970126498536964, 0.2788382659435551],
              [0.4702337852356998, 0.5036770083784342, 0.2694548090548239], 0.012127341858664119)]
    prims = [Primitive(k, np.asarray(a, float), np.asarray(b, float), r) for k, a, b, r in rows]
    bores = [_cyl(a, b, r) for a, b, r in holes]
    assert len(step_mod.coaxial_groups(bores)) == 2  # the first joint's three, the far joint's two
    mesh = _solid([primitive_solid(p) for p in prims], [primitive_solid(b) for b in bores])
    volume = signed_volume(mesh.triangles)
    with _occ_model("link_h1") as occ:
        tags, k = step_mod._checked_solids(occ, prims, bores, 1.0, volume, 1, name="link_h1")
        assert len(tags) == 1 and occ.getMass(3, tags[0]) == pytest.approx(volume, rel=0.02)


def test_part_accuracies_follow_each_product_to_its_uncertainty():
    """`part_accuracies`: PRODUCT -> formation -> definition -> its shape -> the B-rep representation -> its
    context -> the uncertainty (line breaks where the translator puts them); the assembly has no B-rep."""
    text = ("#7 = PRODUCT('linkage','linkage','',(#8));\n#9 = PRODUCT_DEFINITION_FORMATION('','',#7);\n"
            "#10 = PRODUCT_DEFINITION('design','',#9,#11);\n"
            "#73 = PRODUCT('link_h1','link_h1','',(#74));\n#72 = PRODUCT_DEFINITION_FORMATION('','',#73);\n"
            "#71 = PRODUCT_DEFINITION('design','',#72,#75);\n#70 = PRODUCT_DEFINITION_SHAPE('','',#71);\n"
            "#69 = SHAPE_DEFINITION_REPRESENTATION(#70,#76);\n"
            "#76 = ADVANCED_BREP_SHAPE_REPRESENTATION('',(#11,#77),#63);\n"
            "#63 = ( GEOMETRIC_REPRESENTATION_CONTEXT(3) \nGLOBAL_UNCERTAINTY_ASSIGNED_CONTEXT((#67)) "
            "GLOBAL_UNIT_ASSIGNED_CONTEXT(\n(#64,#65,#66)) REPRESENTATION_CONTEXT('Context #1',\n  '3D Context') );\n"
            "#67 = UNCERTAINTY_MEASURE_WITH_UNIT(LENGTH_MEASURE(5.E-02),#64,\n  'distance_accuracy_value',"
            "'confusion accuracy');\n")
    assert step_mod.part_accuracies(text) == {"link_h1": 0.05}


def test_no_step_leaves_linkage_step_out_and_the_rest_as_it_was(tmp_path, monkeypatch):
    """`--no-step`: no linkage.step and no warning about it, linkage.json's ``step`` false, every other file
    the bytes of a run with it; `mpsynth export OUT --step` adds it afterwards (with the cad extra)."""
    import json

    from cli.main import mpsynth as cli

    fixture = str(REPO / "fixtures/bennett_mm_deg.yaml")
    r = CliRunner().invoke(cli, ["bennett", fixture, "-o", str(tmp_path / "full")])
    assert r.exit_code == 0, r.output

    def never(*args, **kwargs):
        raise AssertionError("linkage.step built although --no-step")

    with monkeypatch.context() as m:
        m.setattr(step_mod, "built_step", never)
        r = CliRunner().invoke(cli, ["bennett", fixture, "-o", str(tmp_path / "lean"), "--no-step"])
    assert r.exit_code == 0, r.output
    assert "linkage.step" not in r.output and "linkage.json, 4 link meshes" in r.output
    full, lean = tmp_path / "full", tmp_path / "lean"
    assert not (lean / "linkage.step").exists()
    names = sorted(p.relative_to(lean).as_posix() for p in lean.rglob("*") if p.is_file() and not p.name.startswith("."))
    assert names == sorted(p.relative_to(full).as_posix() for p in full.rglob("*")
                           if p.is_file() and not p.name.startswith(".") and p.name != "linkage.step")
    for name in names:
        if name != "linkage.json":
            assert (lean / name).read_bytes() == (full / name).read_bytes(), name
    doc, ref = (json.loads((d / "linkage.json").read_text()) for d in (lean, full))
    assert doc.pop("step") is False and ref.pop("step") is step_mod.have_kernel() and doc == ref
    if step_mod.have_kernel():
        r = CliRunner().invoke(cli, ["export", str(lean), "--step"])
        assert r.exit_code == 0, r.output
        assert (lean / "linkage.step").read_text() == (full / "linkage.step").read_text()
        assert json.loads((lean / "linkage.json").read_text())["step"] is True


def test_writing_without_step_does_not_load_the_kernel(tmp_path):
    """A design written with `Outputs.NO_STEP`'s formats neither imports nor initialises gmsh (a batch worker
    with --no-step pays nothing for the cad extra)."""
    code = (f"import sys, synth; from synth.io.poses import load_poses; from synth.design.choose import design_for; "
            f"from synth.io.outputs import Outputs; from synth.io.writer import write_output; "
            f"lk = synth.bennett(load_poses({str(REPO / 'fixtures/bennett_mm_deg.yaml')!r}).matrices); "
            f"write_output(lk, {str(tmp_path / 'o')!r}, robot_name='b', result=design_for(lk), "
            f"formats=Outputs.NO_STEP.formats); assert 'gmsh' not in sys.modules, 'gmsh imported'")
    subprocess.run([sys.executable, "-c", code], check=True, cwd=REPO)
    assert (tmp_path / "o" / "linkage.urdf").exists() and not (tmp_path / "o" / "linkage.step").exists()
