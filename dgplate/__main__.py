"""``python -m dgplate`` is the ``dgplate`` command."""

import sys

from dgplate.cli import main

if __name__ == "__main__":  # not when a documentation tool imports every module
    sys.exit(main())
