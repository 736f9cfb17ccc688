"""Many cases of one body and loads per kernel call: the ensemble kernels, their observables, and the Python that runs a block of cases."""
