"""``python -m msfd_jax.cli``: the same as the ``msfd`` script."""

import sys

from . import main

if __name__ == "__main__":  # not in a spawned child (Dask's LocalCluster workers)
    sys.exit(main())
