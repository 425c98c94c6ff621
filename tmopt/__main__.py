"""``python -m tmopt``: see :mod:`tmopt.run.cli`."""

from tmopt.run.cli import main

if __name__ == "__main__":
    main()
