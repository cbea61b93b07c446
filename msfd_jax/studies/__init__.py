"""Studies of the solver: what the paper's figures, the closed forms and the numerics say.

Kept apart from the solver core (`msfd_jax`'s private modules) as optax keeps its less central
code in ``optax/contrib``: a study imports the core, the core never imports a study.

- `reproduce`: the paper's Sect. 4 figures and findings (``msfd reproduce``);
- `accuracy`: the work-precision study (``msfd bench accuracy``, docs/accuracy.md);
- `stability`: the catalogue of stiff and extreme scenes (``msfd bench stability``);
- `references`: closed forms the solver is checked against (Eq. 25, Parkes, the Appendix);
- ``scripts/``: the scripts that write validation and accuracy numbers to
  ``benchmarks/results`` and ``docs/figures`` (``python -m msfd_jax.studies.scripts.NAME``).

Nothing here is imported by ``import msfd_jax``.
"""
