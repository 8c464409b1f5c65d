"""MoFusion (CVPR 2023): the ``mofusion`` method, its generation API and its table recipes.

* :mod:`~momu.methods.mofusion.method` — :class:`MoFusion` (registered ``mofusion``): training;
* :mod:`~momu.methods.mofusion.model` — :class:`MoFusionModel`: generation (music→dance, text→motion,
  forecasting, in-betweening, text-based editing), save / load;
* :mod:`~momu.methods.mofusion.tables` — Table 1, Table 2, supp. Tables 1–2 (``recipes/mofusion_*.py``).
"""

from momu.methods.mofusion.config import MoFusionConfig, MoFusionEvalConfig
from momu.methods.mofusion.method import MoFusion, build_mofusion
from momu.methods.mofusion.model import MoFusionModel

__all__ = ["MoFusion", "MoFusionConfig", "MoFusionEvalConfig", "MoFusionModel", "build_mofusion"]
