"""The text of ``linkage.step`` as the translator writes it, edited and read (`synth.io.step`): the parts
named as in the URDF and placed by their assembly occurrences, the file made reproducible, and each part's
accuracy (OpenCASCADE's tolerance) read back. Pure string work over ISO 10303-21 entity text."""
from __future__ import annotations

import re

def name_products(text: str, names: list[str]) -> str:
    """The STEP ``text`` with the k-th part PRODUCT (the ones the translator numbers "n.k", n counting
    the files written in this process) named ``names[k - 1]`` and the assembly ("n") named "linkage";
    and what else depends on the process or the clock made reproducible: the assembly occurrences
    numbered 1, 2, ... in file order, the header's file name "linkage" and time stamp the epoch.
    ValueError when the counts differ."""
    pattern = re.compile(r"PRODUCT\('Open CASCADE STEP translator \S+ \d+(\.(\d+))?',\s*'[^']*'")
    seen = []

    def rename(m):
        if m.group(2) is None:
            return "PRODUCT('linkage','linkage'"
        k = int(m.group(2))
        seen.append(k)
        return f"PRODUCT('{names[k - 1]}','{names[k - 1]}'" if k <= len(names) else m.group(0)

    out = pattern.sub(rename, text)
    if sorted(seen) != list(range(1, len(names) + 1)):
        raise ValueError(f"the STEP file has {len(seen)} parts, expected {len(names)}")
    count = iter(range(1, 1 << 30))
    out = re.sub(r"NEXT_ASSEMBLY_USAGE_OCCURRENCE\('\d+'", lambda m: f"NEXT_ASSEMBLY_USAGE_OCCURRENCE('{next(count)}'",
                 out)
    return re.sub(r"FILE_NAME\('[^']*','[^']*'", "FILE_NAME('linkage','1970-01-01T00:00:00'", out, count=1)


def _entities(pattern: re.Pattern, text: str) -> dict[str, tuple]:
    """{entity number: groups} of the matches of ``pattern`` (from " = KEYWORD(") in ``text``."""
    return {text[text.rfind("#", 0, m.start()) + 1 : m.start()]: m.groups() for m in pattern.finditer(text)}


_ASSEMBLY = {  # what `place_products` follows: {kind: pattern from " = KEYWORD(" (`_entities`)}
    "nauo": re.compile(r" = NEXT_ASSEMBLY_USAGE_OCCURRENCE\(\s*'(\d+)'"),
    "pds": re.compile(r" = PRODUCT_DEFINITION_SHAPE\(\s*'[^']*',\s*'[^']*',\s*#(\d+)\s*\)"),
    "cdsr": re.compile(r" = CONTEXT_DEPENDENT_SHAPE_REPRESENTATION\(\s*#(\d+),\s*#(\d+)\s*\)"),
    "rrwt": re.compile(r" = \( REPRESENTATION_RELATIONSHIP\([^;]*?"
                       r"REPRESENTATION_RELATIONSHIP_WITH_TRANSFORMATION\(\s*#(\d+)\s*\)"),
    "idt": re.compile(r" = ITEM_DEFINED_TRANSFORMATION\(\s*'[^']*',\s*'[^']*',\s*#(\d+),\s*#(\d+)\s*\)"),
    "axis": re.compile(r" = AXIS2_PLACEMENT_3D\(\s*'[^']*',\s*#(\d+),"),
}
_ZERO_POINT = re.compile(r"^#(\d+) = CARTESIAN_POINT\('',\(0\.,0\.,0\.\)\);$", re.M)


def place_products(text: str, origins: list) -> str:
    """The STEP ``text`` with the k-th part occurrence (NEXT_ASSEMBLY_USAGE_OCCURRENCE 'k', as `name_products`
    numbers them: the writer's order) placed at ``origins[k - 1]`` (3,) in the file's unit: the origin of
    its ITEM_DEFINED_TRANSFORMATION's target placement, written as identity by the translator. Each part
    is built around its own origin (`local_origin`), so its geometry keeps the file's 13 significant
    digits where the linkage is far from the world origin. ValueError when the structure is not found."""
    found = {k: _entities(p, text) for k, p in _ASSEMBLY.items()}
    nauo = {k: i for i, (k,) in found["nauo"].items()}
    pds = {n: i for i, (n,) in found["pds"].items()}
    cdsr = {d: r for _, (r, d) in found["cdsr"].items()}
    points = {}
    for k, origin in enumerate(origins, 1):
        try:
            (transform,) = found["rrwt"][cdsr[pds[nauo[str(k)]]]]
            point = found["axis"][found["idt"][transform][1]][0]  # ITEM_DEFINED_TRANSFORMATION('','',#from,#to)
        except KeyError:
            raise ValueError(f"the STEP file has no placement for part occurrence {k}") from None
        if point in points:
            raise ValueError(f"part occurrences share the placement #{point}")
        points[point] = "CARTESIAN_POINT('',(" + ",".join(_step_real(x) for x in origin) + "))"
    out = _ZERO_POINT.sub(lambda m: f"#{m.group(1)} = {points.pop(m.group(1))};" if m.group(1) in points
                          else m.group(0), text)
    if points:
        raise ValueError(f"part placements #{', #'.join(points)} are not the translator's identity")
    return out


def _step_real(x: float) -> str:
    """``x`` as a STEP real (ISO 10303-21: a decimal point, an optional exponent), round-tripping."""
    r = repr(float(x) + 0.0)
    mant, _, exp = r.partition("e")
    mant = mant if "." in mant else mant + "."
    return mant + (f"E{int(exp)}" if exp else "")


_ACCURACY = {  # what `part_accuracies` follows, from a part's PRODUCT to its uncertainty: {kind: pattern}, each
    # from the " = KEYWORD(" of an entity "#n = KEYWORD(...)" (a literal start: the regex engine skips to it)
    "product": re.compile(r" = PRODUCT\(\s*'([^']*)'"),
    "pdf": re.compile(r" = PRODUCT_DEFINITION_FORMATION\(\s*'[^']*',\s*'[^']*',\s*#(\d+)\s*\)"),
    "pd": re.compile(r" = PRODUCT_DEFINITION\(\s*'[^']*',\s*'[^']*',\s*#(\d+),"),
    "pds": _ASSEMBLY["pds"],
    "sdr": re.compile(r" = SHAPE_DEFINITION_REPRESENTATION\(\s*#(\d+),\s*#(\d+)\s*\)"),
    "brep": re.compile(r" = ADVANCED_BREP_SHAPE_REPRESENTATION\(\s*'[^']*',\s*\([^)]*\),\s*#(\d+)\s*\)"),
    "context": re.compile(r" = \( GEOMETRIC_REPRESENTATION_CONTEXT\(\d\)\s*"
                          r"GLOBAL_UNCERTAINTY_ASSIGNED_CONTEXT\(\(\s*#(\d+)\s*\)\)"),
    "measure": re.compile(r" = UNCERTAINTY_MEASURE_WITH_UNIT\(\s*LENGTH_MEASURE\(([^)]*)\)"),
}


def part_accuracies(text: str) -> dict[str, float]:
    """{part name: its B-rep's distance accuracy, in the file's unit} of a STEP ``text``: the uncertainty of
    the representation context of each PRODUCT's solid (OpenCASCADE writes its shape's largest tolerance
    there: 1e-7 model units, raised where a boolean could not meet it). Parts without a solid (the
    assembly) are left out."""
    found = {k: _entities(p, text) for k, p in _ACCURACY.items()}
    names = {i: n for i, (n,) in found["product"].items()}
    shape_of = {pds: rep for _, (pds, rep) in found["sdr"].items()}
    shape_of_definition = {d: i for i, (d,) in found["pds"].items()}
    out = {}
    for pd, (pdf,) in found["pd"].items():
        rep = shape_of.get(shape_of_definition.get(pd))
        if rep not in found["brep"]:
            continue
        (context,) = found["brep"][rep]
        (measure,) = found["context"][context]
        out[names[found["pdf"][pdf][0]]] = float(found["measure"][measure][0])
    return out
