"""Batch runs of scenario suites (CI) — runner and reports."""
