"""One run and the command line, above the algorithms.

``cli`` (``python -m tmopt``: pre-flight checks, then Hydra), ``config`` (the run
settings' schema, key and type checks, the configuration hash), ``build`` (problem and
algorithm from a composed configuration), ``runner`` (ask -> evaluate -> tell until the
budget is spent), ``progress`` (one line per generation), ``outputs`` and ``plots`` (the
files a finished run leaves in its folder).
"""
