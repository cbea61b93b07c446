"""``python -m msfd_jax.cli``: the same as the ``msfd`` script."""

import sys

from . import main

sys.exit(main())
