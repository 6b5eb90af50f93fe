"""Moved to :mod:`pbr_xval.analytical.adapters` (the adapters that make the Housner and curved-base solutions answer as engines); this old path is kept so existing imports work.

``import pbr_xval.analytical.engines`` gives the very module object of :mod:`pbr_xval.analytical.adapters`.
"""

import sys

from pbr_xval.analytical import adapters as _moved
from pbr_xval.analytical.adapters import *  # noqa: F403

sys.modules[__name__] = _moved
