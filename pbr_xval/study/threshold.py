"""Moved to :mod:`pbr_xval.study.threshold_search` (the toppling-threshold search over one scalar parameter); this old path is kept so existing imports work.

``import pbr_xval.study.threshold`` gives the very module object of :mod:`pbr_xval.study.threshold_search`.
"""

import sys

from pbr_xval.study import threshold_search as _moved
from pbr_xval.study.threshold_search import *  # noqa: F403

sys.modules[__name__] = _moved
