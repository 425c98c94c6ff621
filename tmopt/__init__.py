"""tmopt: expensive constrained multi-objective optimisation with surrogate models.

Flagship problem: on-orbit identification of test-mass stiffness in space
gravitational-wave detectors (Tang et al., Aerospace 12(8), 673, 2025).

The Python API (docs/python-api.md), imported on first use so that ``import tmopt`` stays
light:

- :func:`run_optimisation` (:mod:`tmopt.run.runner`): any tmopt or pymoo algorithm on any
  tmopt or pymoo problem for a budget of real evaluations;
- :func:`simulate` (the module :mod:`tmopt.simulate`, callable): one closed-loop
  stiffness-identification simulation;
- :func:`diagnose`: the mismatch diagnosis of a recording (:mod:`tmopt.mismatch`);
- algorithms: ``from tmopt.algorithms import MGSAEAIPC, NSGA2, ...``, each also a pymoo
  algorithm (``pymoo.optimize.minimize(problem, MGSAEAIPC(), ("n_evals", 300))``).
"""

from __future__ import annotations

__version__ = "0.1.0"
__all__ = ["diagnose", "run_optimisation", "simulate"]


def diagnose(recording, settings=None, out=None):
    """Locate, explain and model the mismatch between the nominal model and ``recording``.

    Args:
        recording: A recording file (``.h5``, or ``.csv`` with its ``.json``; see
            docs/recording-format.md) or a :class:`tmopt.physics.recording.Recording`.
        settings: :class:`tmopt.mismatch.diagnose.Settings` (None: the calibrated defaults).
        out: Folder for report.md, report.json and the plots (None: write nothing).

    Returns:
        The :class:`tmopt.mismatch.diagnose.Diagnosis` (``.selected`` effects,
        ``.mismatch_detected``, fits before and after), as ``python -m tmopt.mismatch``.
    """
    from tmopt.mismatch.diagnose import diagnose as _diagnose
    from tmopt.mismatch.fit import data_from_recording
    from tmopt.physics.recording import Recording, read_recording

    rec = recording if isinstance(recording, Recording) else read_recording(recording)
    result = _diagnose(data_from_recording(rec), settings)
    if out is not None:
        from tmopt.mismatch.report import write_report

        write_report(result, out)
    return result


def __getattr__(name: str):
    if name == "run_optimisation":
        from tmopt.run.runner import run_optimisation

        return run_optimisation
    if name == "simulate":
        import tmopt.simulate as module  # a callable module: simulate(...) runs it

        return module
    raise AttributeError(f"module 'tmopt' has no attribute {name!r}")
