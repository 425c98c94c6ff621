"""tmopt's Hydra sweeper (``hydra/sweeper=tmopt``): Hydra's basic sweeper that launches
only a sweep's unfinished runs (:mod:`tmopt.run.sweep_resume`). Hydra finds sweepers only in
the ``hydra_plugins`` namespace package, hence this package beside ``tmopt``."""
