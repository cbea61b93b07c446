"""Closed-form references: Eq. 25 and Parkes' cantilever (`analytic`), the Appendix (`appendix`)."""
