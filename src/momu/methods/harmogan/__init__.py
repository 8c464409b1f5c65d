"""HarmoGAN (HarmoGAN §III–V): the ``harmogan`` method, its trained model and its tables.

* :mod:`.meter` — meter segmentation, meter units, TI and Eq. 12 (§IV-A, Fig. 6);
* :mod:`.data` — dances at 15 fps, the temporal split, the meter-unit dataset, evaluation windows;
* :mod:`.config` — :class:`HarmoGANConfig` (every §V-B number a field);
* :mod:`.stages` — pretraining and adversarial stages (Eq. 13–20);
* :mod:`.method` — :class:`HarmoGAN` (the registered method: parts, stage keys, training);
* :mod:`.model` — :class:`HarmoGANModel` (recurrent generation over meter units, save / load);
* :mod:`.ballroom` — the Ballroom test clips (§V-A);
* :mod:`.calibration`, :mod:`.evaluate`, :mod:`.recipes` — the tables and figures.
"""

from momu.methods.harmogan.config import HarmoGANConfig
from momu.methods.harmogan.method import HarmoGAN, build_harmogan
from momu.methods.harmogan.model import HarmoGANModel

__all__ = ["HarmoGANConfig", "HarmoGAN", "HarmoGANModel", "build_harmogan"]
