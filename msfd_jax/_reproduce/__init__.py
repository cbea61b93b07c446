"""``msfd reproduce``: the paper's Sect. 4, figure by figure (see `_common.Reproduction`)."""
