"""Moved to :mod:`pbr_xval.validation.execution` (running a campaign's tests through the catalog machinery); this old path is kept so existing imports work.

``import pbr_xval.validation.runner`` gives the very module object of :mod:`pbr_xval.validation.execution`.
"""

import sys

from pbr_xval.validation import execution as _moved
from pbr_xval.validation.execution import *  # noqa: F403
from pbr_xval.validation.execution import _safe  # noqa: F401  (imported by validation/ensemble.py)

sys.modules[__name__] = _moved
