"""Moved to :mod:`pbr_xval.hazard.constrain_report` (the pbr-xval constrain report); this old path is kept so existing imports work.

``import pbr_xval.hazard.report`` gives the very module object of :mod:`pbr_xval.hazard.constrain_report`.
"""

import sys

from pbr_xval.hazard import constrain_report as _moved
from pbr_xval.hazard.constrain_report import *  # noqa: F403

sys.modules[__name__] = _moved
