"""Real evaluations, below the algorithms: every expensive call of a run goes through here.

``evaluator`` (budget counting, failure isolation, resume by replay), ``archive`` (the
append-only, atomically rewritten store of every real evaluation, ``archive.h5``) and
``isolation`` (evaluations under a time limit in a worker process). Algorithms receive
:class:`~tmopt.evaluation.evaluator.EvaluatedBatch` objects from here and never call a
problem themselves.
"""
