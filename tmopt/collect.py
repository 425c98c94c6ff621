"""``python -m tmopt.collect``: the command's name; the code is :mod:`tmopt.reporting.collect`."""

import sys

from tmopt.reporting.collect import main

if __name__ == "__main__":
    sys.exit(main())
