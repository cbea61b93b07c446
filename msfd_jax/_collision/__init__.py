"""One collision: `run` and what it reports.

`attempts` (the retry policy at a smaller step, and `Attempts`, which attempt a row reports),
`provenance` (versions, settings and mesh records, strict JSON), `run` (`run`, `Collision`,
`fractions`, `diagnose`).
"""
