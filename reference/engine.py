"""Moved to :mod:`pbr_xval.reference.adapter` (the adapter that makes the LCP solver answer as the
``reference`` engine); this old path is kept so existing imports work.

``import pbr_xval.reference.engine`` gives the very module object of :mod:`pbr_xval.reference.adapter`.
"""

import sys

from pbr_xval.reference import adapter as _moved
from pbr_xval.reference.adapter import *  # noqa: F403

sys.modules[__name__] = _moved
