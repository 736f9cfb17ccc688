"""Pure numerical kernels (numba-compiled where hot). Kernels never see a config object."""
