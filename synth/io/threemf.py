"""3MF files (3D Manufacturing Format, core specification 1.x) of print plates: one ZIP package per plate
holding ``3D/3dmodel.model``, an XML model in millimetres with one named mesh object per part and one
build item per object placing it on the plate (a translation).

Written in plain Python (``zipfile`` and text), byte for byte the same for the same parts: every ZIP entry
dated 1980-01-01, no UUIDs. Meshes are indexed (`synth.io.solid.Solid`: vertices (n, 3) mm, faces (m, 3)
wound counter-clockwise seen from outside, as 3MF requires).
"""
from __future__ import annotations

import io
import zipfile
from xml.sax.saxutils import quoteattr

import numpy as np

CONTENT_TYPES = ('<?xml version="1.0" encoding="UTF-8"?>\n'
                 '<Types xmlns="http://schemas.openxmlformats.org/package/2006/content-types">'
                 '<Default Extension="rels" ContentType="application/vnd.openxmlformats-package.relationships+xml"/>'
                 '<Default Extension="model" ContentType="application/vnd.ms-package.3dmanufacturing-3dmodel+xml"/>'
                 '</Types>')
RELS = ('<?xml version="1.0" encoding="UTF-8"?>\n'
        '<Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships">'
        '<Relationship Target="/3D/3dmodel.model" Id="rel0" '
        'Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/></Relationships>')
NAMESPACE = "http://schemas.microsoft.com/3dmanufacturing/core/2015/02"


def _number(x: float) -> str:
    return f"{x:.6f}".rstrip("0").rstrip(".") if np.isfinite(x) else "0"


def model_xml(parts: list[tuple[str, object, tuple[float, float, float]]]) -> str:
    """The 3MF model of ``parts`` [(name, Solid in mm, (x, y, z) mm offset on the plate)]."""
    out = [f'<?xml version="1.0" encoding="UTF-8"?>\n<model unit="millimeter" xml:lang="en-US" xmlns="{NAMESPACE}">',
           "<resources>"]
    for k, (name, mesh, _) in enumerate(parts, start=1):
        out.append(f'<object id="{k}" name={quoteattr(name)} type="model"><mesh><vertices>')
        out += [f'<vertex x="{_number(a)}" y="{_number(b)}" z="{_number(c)}"/>' for a, b, c in mesh.vertices]
        out.append("</vertices><triangles>")
        out += [f'<triangle v1="{a}" v2="{b}" v3="{c}"/>' for a, b, c in mesh.faces]
        out.append("</triangles></mesh></object>")
    out.append("</resources><build>")
    for k, (_, _, (x, y, z)) in enumerate(parts, start=1):
        out.append(f'<item objectid="{k}" transform="1 0 0 0 1 0 0 0 1 {_number(x)} {_number(y)} {_number(z)}"/>')
    out.append("</build></model>")
    return "\n".join(out)


def threemf_bytes(parts: list[tuple[str, object, tuple[float, float, float]]]) -> bytes:
    """The 3MF package (ZIP bytes) of ``parts`` (see `model_xml`)."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        for path, text in (("[Content_Types].xml", CONTENT_TYPES), ("_rels/.rels", RELS),
                           ("3D/3dmodel.model", model_xml(parts))):
            info = zipfile.ZipInfo(path, date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            z.writestr(info, text.encode("utf-8"))
    return buf.getvalue()
