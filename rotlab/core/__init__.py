"""Pure numerical kernels (numba-compiled where hot). Kernels never see a config object."""

from rotlab.core import kernel_cache

kernel_cache.install()  # before any kernel is defined: a change to any kernel source recompiles all
