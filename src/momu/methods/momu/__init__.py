"""MoMu-Diffusion (MoMu §3–5, App. A–E): the ``momu`` method, its trained model and its tables.

* :mod:`.config` — :class:`MoMuConfig` / :class:`MoMuEvalConfig`;
* :mod:`.method` — :class:`MoMu` (the registered method: parts, stage keys, training);
* :mod:`.model` — :class:`MoMuModel` (generation, save / load);
* :mod:`.data`, :mod:`.stages` — training windows and the three trainable stages;
* :mod:`.learnable` — the learnable-motion-encoder model of Tables 3–4;
* :mod:`.recipes`, :mod:`.tables` and :mod:`.evaluate` — the table specs and their evaluation.
"""

from momu.methods.momu.config import MoMuConfig, MoMuEvalConfig, backbone_node
from momu.methods.momu.method import MoMu, build_momu
from momu.methods.momu.model import MoMuModel, sample_items

__all__ = ["MoMuConfig", "MoMuEvalConfig", "MoMu", "MoMuModel", "backbone_node", "build_momu", "sample_items"]
