"""Methods: one module each behind the ``Method`` interface (see base.py)."""
