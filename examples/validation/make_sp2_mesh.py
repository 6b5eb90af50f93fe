"""Write ``sp2.rock.obj``: the closed surface of specimen SP2 reconstructed from its point cloud.

SP2 was scanned as a point cloud (``../shared/data/scans/SP2_points.ply``); a scenario needs a
closed mesh, so this script reconstructs it with the project's own pipeline (alpha solid,
:func:`pbr_xval.geometry.rockmodel.build_rock_model`, the route of ``pbr-xval rock --scenario``)
and writes it beside ``sp2.toml`` in the scan's (re-centred) orientation. The mesh is derived
from the shared data and is not committed; run this once after cloning (from the repo root)::

    python examples/validation/make_sp2_mesh.py

The reconstruction is deterministic (Delaunay + alpha filtering), so the file — and every stored
result keyed by its SHA-256 — is the same on every machine with the same library versions.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
SCAN = HERE.parents[1].parent / "shared" / "data" / "scans" / "SP2_points.ply"
OUT = HERE / "sp2.rock.obj"


def main(scan: Path = SCAN) -> int:
    """Reconstruct the mesh from ``scan`` (SP2's point cloud) into ``sp2.rock.obj``; 0 on success, 2 if absent."""
    from pbr_xval.atomic import write_text_atomic
    from pbr_xval.geometry.rockmodel import build_rock_model

    if not scan.is_file():
        print(f"error: {scan} not found (the shared data must sit beside the repository)", file=sys.stderr)
        return 2
    model = build_rock_model(scan, density=None, mass=353.8, pose="settle")
    local = model.mesh.copy()
    local.apply_transform(np.linalg.inv(model.transform))  # back to the re-centred scan orientation
    write_text_atomic(OUT, local.export(file_type="obj"))
    print(f"wrote {OUT} ({len(local.vertices)} vertices, volume {local.volume:.6f} m³)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
