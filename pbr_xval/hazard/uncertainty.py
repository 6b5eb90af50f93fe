"""Moved to :mod:`pbr_xval.hazard.fragility_draws` (the fragility's draws carried into P_s and the
reweighted hazard; distinct from :mod:`pbr_xval.uncertainty`, a scenario's ensemble); this old path
is kept so existing imports work.

``import pbr_xval.hazard.uncertainty`` gives the very module object of :mod:`pbr_xval.hazard.fragility_draws`.
"""

import sys

from pbr_xval.hazard import fragility_draws as _moved
from pbr_xval.hazard.fragility_draws import *  # noqa: F403

sys.modules[__name__] = _moved
