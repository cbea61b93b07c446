"""Sweeps: many collisions on the batched core.

`queue` (slots refilled from a queue: the sweep engine), `shard` (the chunked vmap /
shard_map path), `cluster` (Dask tasks), `table` (`SweepTable`), `store` (rows written as
they finish, read to resume), `sweep` (`sweep`, `solve_collisions`).
"""
