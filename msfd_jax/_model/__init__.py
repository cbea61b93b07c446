"""The model: what a collision is, independent of how it is integrated.

In import order: `safe` (NaN-free maths), `laws` (one spring's return mapping), `params`
(non-dimensional groups, mesh, SI conversion, validation), `chain` (chains of rigid segments),
`contact` (contact sets), `collapse` (the contacts of a collapsing structure), `scene` (the
scenes: ring on beam, ring on plate, ...), `state` (the state, its deformations and the
stability limit), `cap` (the time cap from the collapse loads), `si` (SI design quantities).
"""
