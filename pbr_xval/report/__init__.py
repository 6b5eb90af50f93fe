"""Report writer: a folder with a self-contained HTML page, a Markdown summary, CSV and Parquet data.

See :func:`pbr_xval.report.writer.write_report`.
"""

from __future__ import annotations

from pbr_xval.report.writer import summary_markdown, write_report

__all__ = ["summary_markdown", "write_report"]
