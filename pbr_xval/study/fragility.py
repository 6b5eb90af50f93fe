"""Moved to :mod:`pbr_xval.study.fragility_map` (fragility maps over a 2-D grid of scenario parameters); this old path is kept so existing imports work.

``import pbr_xval.study.fragility`` gives the very module object of :mod:`pbr_xval.study.fragility_map`.
"""

import sys

from pbr_xval.study import fragility_map as _moved
from pbr_xval.study.fragility_map import *  # noqa: F403

sys.modules[__name__] = _moved
