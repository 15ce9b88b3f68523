"""Helpers for tests and benchmarks, not for measuring: generated scenes checked against the
automatic parameters (``autocheck``) and a rendered outcrop video with exact truth (``render``).
Kept in the package so that benchmarks and users' own checks can use them too."""
