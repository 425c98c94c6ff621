"""``python -m tmopt.design RECORDING_OR_REPORT --out DIR``."""

import sys

from tmopt.design.cli import main

if __name__ == "__main__":
    sys.exit(main())
