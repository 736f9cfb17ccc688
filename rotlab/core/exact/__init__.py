"""Exact (closed-form / elliptic-function) solutions, evaluated directly at sample times."""
