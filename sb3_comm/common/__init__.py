"""Pieces shared by the algorithms and wrappers."""
