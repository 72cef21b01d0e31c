"""Exporters: write a `Linkage` as OUTPUT.md's directory (linkage.urdf, linkage.json, meshes/*.stl).

Modules: frames (link frames, rpy), meshes (link solids), urdf (URDF text), jsonout (linkage.json),
writer (atomic output directory). trimesh is imported only when meshes are built.
"""
from .jsonout import linkage_document, write_json
from .urdf import urdf_text
from .writer import atomic_directory, write_linkage_files, write_output

__all__ = ["write_output", "linkage_document", "urdf_text", "atomic_directory", "write_json",
           "write_linkage_files"]
