"""Parameter sweeps: expand ``[sweep]`` into cases, run them (processes, Dask, or one ensemble
kernel call), report a results table and a comparison recording."""
