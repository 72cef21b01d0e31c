"""Synthesis: task poses or curves in, linkages out (conic, cubic families, Bennett, 6R, curves)."""
