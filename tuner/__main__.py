"""``python -m tuner``: the ``tuner`` command.

``python -m`` puts the working directory first on ``sys.path``; the ``tuner`` script does not. It is
removed here, so a module lying beside a handed-over run directory (``numpy.py``, or the module a
``kind: python`` config names) is never imported in place of an installed one: both forms import the
same code (``PYTHONPATH`` still adds folders on purpose).
"""

import os
import sys

if sys.path and sys.path[0] in ("", os.getcwd()) and not sys.flags.safe_path:
    del sys.path[0]

from tuner.cli import main  # noqa: E402

sys.exit(main())
