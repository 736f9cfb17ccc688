"""``rotlab stress``: hard scenes with pass/fail figures (numerical stability and robustness)."""
