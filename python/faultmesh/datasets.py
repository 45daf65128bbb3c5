"""Built-in and generated datasets (paper-like and synthetic), with ground truth.

Being written: ``paper_like`` and ``synthetic`` follow in the next commits.
"""
from __future__ import annotations
