"""``python -m faultmesh``: the same as the ``faultmesh`` command."""
import sys

from .cli import main

sys.exit(main())
