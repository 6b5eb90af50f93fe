"""``python -m pbr_xval.catalog sweep CATALOG OUT [--executor local|dask] [--workers N] [--shard i/N]``
and ``python -m pbr_xval.catalog choose CATALOG --budget 0.05 OUT`` (the same functions as the CLI)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    from pbr_xval.cli.catalog_impl import choose_command, sweep_command

    p = argparse.ArgumentParser(prog="python -m pbr_xval.catalog")
    sub = p.add_subparsers(dest="cmd", required=True)
    s = sub.add_parser("sweep")
    s.add_argument("catalog", type=Path)
    s.add_argument("out", type=Path)
    s.add_argument("--engine", action="append", dest="engines")
    s.add_argument("--profile")
    s.add_argument("--executor", default="local", choices=["local", "dask", "inline"])
    s.add_argument("--workers", type=int)
    s.add_argument("--scheduler")
    s.add_argument("--shard")
    s.add_argument("--chunk-size", type=int, default=0)
    c = sub.add_parser("choose")
    c.add_argument("catalog", type=Path)
    c.add_argument("out", type=Path)
    c.add_argument("--budget", type=float, default=0.05)
    a = p.parse_args(argv)
    if a.cmd == "sweep":
        return sweep_command(
            a.catalog, a.out, a.engines, a.profile, a.executor, a.workers, a.scheduler, a.shard, a.chunk_size
        )
    return choose_command(a.catalog, a.budget, a.out)


if __name__ == "__main__":
    sys.exit(main())
