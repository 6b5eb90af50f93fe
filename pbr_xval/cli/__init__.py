"""The ``pbr-xval`` command line: one module per command group, all on one typer app.

Every command imports what it needs inside its body, so ``pbr-xval --help`` loads no engine.
"""

from __future__ import annotations

# Importing a command group registers its commands; this order is the order of `pbr-xval --help`.
from pbr_xval.cli import simulate  # noqa: F401  # isort: skip
from pbr_xval.cli import rock, report, catalog  # noqa: F401  # isort: skip
from pbr_xval.cli import hazard  # noqa: F401  # isort: skip
from pbr_xval.cli import validate  # noqa: F401  # isort: skip
from pbr_xval.cli import predict  # noqa: F401  # isort: skip
from pbr_xval.cli._app import app

__all__ = ["app", "main"]


def main() -> None:  # pragma: no cover
    app(prog_name="pbr-xval")


if __name__ == "__main__":  # pragma: no cover
    main()
