"""Dual quaternions, motion polynomials and their factorization (no synthesis, no I/O)."""
