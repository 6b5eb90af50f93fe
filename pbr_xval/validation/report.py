"""Moved to :mod:`pbr_xval.validation.campaign_report` (scoring a validation campaign and writing its report); this old path is kept so existing imports work.

``import pbr_xval.validation.report`` gives the very module object of :mod:`pbr_xval.validation.campaign_report`.
"""

import sys

from pbr_xval.validation import campaign_report as _moved
from pbr_xval.validation.campaign_report import *  # noqa: F403

sys.modules[__name__] = _moved
