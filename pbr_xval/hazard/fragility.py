"""Moved to :mod:`pbr_xval.hazard.fragility_functions` (the fragility functions for hazard work); this old path is kept so existing imports work.

``import pbr_xval.hazard.fragility`` gives the very module object of :mod:`pbr_xval.hazard.fragility_functions`.
"""

import sys

from pbr_xval.hazard import fragility_functions as _moved
from pbr_xval.hazard.fragility_functions import *  # noqa: F403

sys.modules[__name__] = _moved
