"""The per-chain reference pipeline: forces by `jax.vjp` of the deformations (Eq. 10).

`dynamics` evaluates the laws and steps one scene's chains (`respond`, `initial_state`,
`verlet_step`); `verlet` wraps that step as a diffrax solver. The batched core must agree with
it (tests/test_engine.py); the accuracy study compares both. Nothing of the batched core is
imported here, nor this from the core.
"""
