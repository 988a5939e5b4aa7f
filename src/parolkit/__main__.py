"""``python -m parolkit`` is the ``parolkit`` command."""

import sys

from parolkit.cli import main

sys.exit(main())
