"""tmopt's Hydra configuration, shipped with the package (Hydra reads it as ``pkg://tmopt.conf``).

``config.yaml`` is the primary configuration; one folder per group (``problem``,
``algorithm``, ``surrogate``, ``scheme``, ``experiment``, ``hydra/launcher``). A user's own
options live in a folder of their own, added with ``--config-dir`` (docs/adding-a-problem.md).
"""
