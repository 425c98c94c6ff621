"""``python -m tmopt``: see :mod:`tmopt.cli`."""

from tmopt.cli import main

if __name__ == "__main__":
    main()
