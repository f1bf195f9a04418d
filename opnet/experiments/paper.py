"""The paper's numbers as data: Table 1 and the ablation of Appendix B, on DFAUST, to set beside ours.

The values are the published ones (d_R ×10⁻⁴ m², d_V, d_E); :mod:`opnet.experiments.report` lays them out beside
the reproduction's rows, and :mod:`opnet.reproduce` trains the ablation's grid (:data:`PAPER_ABLATION_SETS` ×
:data:`PAPER_ABLATION_DEPTHS`).
"""

from __future__ import annotations

from ..shape_difference import CHANNEL_SETS

__all__ = ["PAPER_TABLE1", "PAPER_ABLATION", "PAPER_ABLATION_SETS", "PAPER_ABLATION_DEPTHS"]

#: The paper's Table 1 (shape reconstruction on DFAUST): its row name → (d_R ×10⁻⁴, d_V, d_E), for reference beside
#: ours. "Comp": operators through computed maps instead of the known correspondence.
PAPER_TABLE1 = {
    "OperatorNet (Int+Ext)": (1.11, 0.014, 0.045),
    "OperatorNet (Int)": (2.41, 0.013, 0.046),
    "OperatorNet (Ext)": (1.25, 0.017, 0.046),
    "Nearest neighbour (Int+Ext)": (25.5, 0.005, 0.043),
    "OperatorNet (Comp)(Ext)": (3.86, 0.021, 0.052),
    "OperatorNet (Comp)(Int+Ext)": (6.22, 0.022, 0.053),
    "FuncChar (Int+Ext)": (28.4, 0.028, 0.110),
    "FuncChar (Int)": (65.1, 0.356, 0.118),
    "SfL": (48.8, 0.081, 0.012),
}
#: The columns of the paper's ablation (Appendix B), in its order: short name → input channels.
PAPER_ABLATION_SETS = CHANNEL_SETS
#: The rows of the paper's ablation (Appendix B): encoder depths (Conv. 8, 8×16, 8×16×32, 8×16×32×64).
PAPER_ABLATION_DEPTHS = (1, 2, 3, 4)
#: The paper's ablation (Appendix B, d_R ×10⁻⁴ on the DFAUST test set): depth → values in
#: :data:`PAPER_ABLATION_SETS` order.
PAPER_ABLATION = {
    1: (8.61, 4.29, 3.78, 3.82, 3.41, 2.56, 2.46),
    2: (9.08, 4.54, 4.28, 4.65, 3.93, 3.10, 3.05),
    3: (9.90, 5.54, 4.91, 5.59, 4.88, 3.71, 3.55),
    4: (11.16, 6.39, 5.93, 6.89, 5.42, 4.35, 4.24),
}
