"""``python -m dgplate`` is the ``dgplate`` command."""

import sys

from dgplate.cli import main

sys.exit(main())
