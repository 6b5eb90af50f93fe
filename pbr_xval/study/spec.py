"""Moved to :mod:`pbr_xval.study.study_file` (reading and validating study files); this old path is kept so existing imports work.

``import pbr_xval.study.spec`` gives the very module object of :mod:`pbr_xval.study.study_file`.
"""

import sys

from pbr_xval.study import study_file as _moved
from pbr_xval.study.study_file import *  # noqa: F403

sys.modules[__name__] = _moved
