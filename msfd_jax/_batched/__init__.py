"""The batched core: B collisions in flat arrays, batch last, each on its own clock.

In import order: `results` (result codes), `flat` (a scene as flat arrays), `collapse_forces`,
`pruning` (the ring-beam contact in blocks, far blocks skipped exactly), `peaks` (running
peaks for the SI quantities), `engine` (closed-form forces, `batch_response`,
`batch_initial_state`, the step and stopping rule), `verlet` (`BatchedVerlet`, the diffrax
solver), `solver` (one batched `solve`), `simulate` (`Settings`, `Solution`, `simulate`).
"""
