"""``python -m ndbg_cli.kernels [--force]``: build the kernel modules ahead of time
(:func:`ndbg_cli.kernels.compiled.main`)."""

import sys

from .compiled import main

sys.exit(main())
