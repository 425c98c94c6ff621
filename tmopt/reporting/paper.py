"""Published numbers of the seed paper, to print beside ours (never used to compute ours).

Tang et al., "Optimization of Test Mass Motion State for Enhancing Stiffness
Identification Performance in Space Gravitational Wave Detection", Aerospace 12(8): 673,
2025. Table 3: one optimisation per algorithm under scheme B with 3 frequencies (the
paper gives single values, no spread and no number of repetitions).
"""

from __future__ import annotations

#: Table 3 columns (our identification keys of the chosen design's TM1) and their headers.
TABLE3_COLUMNS: tuple[tuple[str, str], ...] = (
    ("convergence_time_TM1", "convergence time (s)"),
    ("convergence_accuracy_TM1", "convergence accuracy (s^-2)"),
    ("M_TM1", "M (default)"),
    ("M_TM1@7e-11", "M (7e-11)"),
    ("M_TM1@5e-11", "M (5e-11)"),
    ("final_accuracy_TM1", "final accuracy (s^-2)"),
)

#: Paper Table 3, keyed by our algorithm config names; values in TABLE3_COLUMNS order.
PAPER_TABLE3: dict[str, tuple[float, float, float, float, float, float]] = {
    "nsga2": (141.0, 1.44e-10, 3.79, 9.73, 10.82, 5.86e-11),
    "nsga3": (125.9, 2.40e-10, 4.50, 7.39, 7.39, 3.60e-12),
    "cmoead": (76.2, 1.13e-09, 12.55, 8.83, 9.52, 5.90e-11),
    "ctsea": (218.8, 2.44e-10, 6.08, 13.53, 13.64, 9.10e-12),
    "ssde": (177.1, 3.34e-10, 6.30, 6.11, 6.23, 2.02e-10),
    "cmoes": (175.1, 1.61e-10, 4.53, 6.75, 6.75, 1.25e-10),
    "mgsaea": (103.7, 4.68e-10, 6.41, 8.99, 8.99, 1.90e-10),
    "mgsaea_star": (191.9, 2.31e-10, 5.51, 11.36, 11.53, 5.50e-11),
    "mgsaea_ipc": (112.1, 1.44e-10, 3.30, 5.75, 5.75, 2.91e-12),
}

#: Display names, in the paper's row order (qlognehvi, kts, drlsaea, pea are ours, not in
#: the paper).
ALGORITHM_NAMES: dict[str, str] = {
    "nsga2": "NSGA-II",
    "nsga3": "NSGA-III",
    "cmoead": "C-MOEA/D",
    "ctsea": "C-TSEA",
    "ssde": "SSDE",
    "cmoes": "CMOES",
    "mgsaea": "MGSAEA",
    "mgsaea_star": "MGSAEA*",
    "mgsaea_ipc": "MGSAEA-IPC",
    "qlognehvi": "qLogNEHVI",
    "kts": "KTS",
    "drlsaea": "DRL-SAEA",
    "pea": "PEA",
}

#: Optimal number of frequencies per scheme read from the paper's Figs. 8-9 (Sec. 4.4).
PAPER_OPTIMAL_K = {"A": 4, "B": 3, "C": 1}


def display_name(algorithm: str) -> str:
    return ALGORITHM_NAMES.get(algorithm, algorithm)


def algorithm_order(algorithm: str) -> int:
    """Sort key: the paper's row order, then ours, then anything else."""
    names = list(ALGORITHM_NAMES)
    return names.index(algorithm) if algorithm in names else len(names)
