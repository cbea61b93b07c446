"""Runtime plumbing, below every layer: it imports nothing of the package.

- `export`: programs serialized with `jax.export` beside the compile cache, so a new process
  loads a stored program instead of tracing it.
- `mappings`: the process's memory-map count, and the release of compiled programs near it.
- `progress`: tqdm progress bars for sweeps and studies.
"""
