"""Rerun recordings: layout (SPEC's stable contract), body shapes, atomic writing."""
