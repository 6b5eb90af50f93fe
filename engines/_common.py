"""Adapter-side helpers for the third-party engine adapters (no engine is imported here).

Geometry for the engines' collision models (:func:`collision_parts`, the OBJ cache
:func:`write_obj`), the key of a compiled model (:func:`model_key`) and the capture of native
stderr (:class:`StderrCapture`). The loop around an engine — settling, the initial tilt, the
drive, sampling, the toppling decision, failure capture — is the stepping core,
:mod:`pbr_xval.stepping`.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import tempfile
import threading
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from pbr_xval.scene import Scene

__all__ = [
    "COLLISION_CHOICES",
    "StderrCapture",
    "cache_dir",
    "check_choices",
    "collision_parts",
    "model_key",
    "write_obj",
]


class StderrCapture:
    """Capture what native code writes to file descriptor 2 (e.g. DART's LCP failure messages)."""

    def __init__(self) -> None:
        self.text = ""

    @contextlib.contextmanager
    def capture(self) -> Iterator[StderrCapture]:
        fd = 2
        saved = os.dup(fd)
        with tempfile.TemporaryFile(mode="w+b") as tmp:
            os.dup2(tmp.fileno(), fd)
            try:
                yield self
            finally:
                os.dup2(saved, fd)
                os.close(saved)
                tmp.seek(0)
                self.text += tmp.read().decode(errors="replace")

    def count(self, needle: str) -> int:
        return self.text.count(needle)


# ------------------------------------------------------------------ geometry
COLLISION_CHOICES = ("auto", "primitive", "boxes", "hull", "coacd", "decimated", "mesh")


def check_choices(engine: str, s: Mapping[str, Any], choices: Mapping[str, tuple[Any, ...]]) -> None:
    """Raise :class:`~pbr_xval.engine.EngineSettingsError` for a setting outside its choices or a timestep ≤ 0."""
    from pbr_xval.engine import EngineSettingsError

    for key, allowed in choices.items():
        if s[key] not in allowed:
            raise EngineSettingsError(
                f"engine {engine!r}: setting {key!r} = {s[key]!r}; expected one of {allowed}"
            )
    if not float(s["timestep"]) > 0:
        raise EngineSettingsError(f"engine {engine!r}: timestep must be > 0 s, got {s['timestep']!r}")
    for key in ("friction", "restitution"):  # "scene": the scene's value, or a number
        if key in s and s[key] != "scene" and not isinstance(s[key], int | float | list):
            raise EngineSettingsError(
                f"engine {engine!r}: setting {key!r} = {s[key]!r}; expected 'scene' or a number"
            )


def model_key(scene: Scene, settings: Mapping[str, Any]) -> str:
    """Hash (hex) of what an adapter's compiled model depends on: geometry, contact, settings.

    Not the excitation: simulations of one scene under different ground motions share a model
    (one compile per worker in a sweep). ``settings`` must be the resolved adapter settings.
    """
    h = hashlib.sha256()

    def feed(x: Any) -> None:
        if isinstance(x, np.ndarray):
            h.update(f"{x.dtype}{x.shape}".encode())
            h.update(np.ascontiguousarray(x).tobytes())
        elif isinstance(x, Mapping):
            for k in sorted(x, key=str):
                h.update(repr(k).encode())
                feed(x[k])
        elif isinstance(x, (list, tuple)):
            h.update(f"{type(x).__name__}{len(x)}".encode())
            for v in x:
                feed(v)
        elif hasattr(x, "vertices") and hasattr(x, "faces"):
            feed(np.asarray(x.vertices))
            feed(np.asarray(x.faces))
        else:
            h.update(repr(x).encode())

    rock = scene.rock
    feed([rock.shape, rock.mesh, rock.com, rock.inertia, float(rock.mass), rock.rotation])
    feed([rock.primitive, rock.box_parts])
    feed([scene.pedestal, scene.collision, scene.mu_s, scene.mu_d, scene.restitution, scene.gravity])
    feed([scene.excitation.vertical is not None, dict(settings)])
    return h.hexdigest()


#: one cached model per engine and thread (an adapter may change a model's options while it runs)
_MODELS = threading.local()
#: models compiled by :func:`cached_model` in this process, per engine (benchmarks check one per worker)
MODEL_BUILDS: dict[str, int] = {}


def cached_model(engine: str, scene: Scene, settings: Mapping[str, Any], build: Any) -> Any:
    """``build()``'s compiled model, reused while the scene geometry and settings stay the same.

    One model per engine and worker process (and thread): a sweep over excitations of one scene (threshold
    search, fragility map) compiles once; a different scene replaces it. ``build`` must return a
    model the adapter does not mutate between runs (or resets at the start of each run).
    """
    key = model_key(scene, settings)
    models: dict[str, tuple[str, Any]] = _MODELS.__dict__.setdefault("models", {})
    hit = models.get(engine)
    if hit is None or hit[0] != key:
        hit = models[engine] = (key, build())
        MODEL_BUILDS[engine] = MODEL_BUILDS.get(engine, 0) + 1
    return hit[1]


def cache_dir() -> Path:
    """Cache directory for derived geometry (``$PBR_XVAL_CACHE`` or ``~/.cache/pbr_xval``)."""
    env = os.environ.get("PBR_XVAL_CACHE")
    return Path(env) if env else Path.home() / ".cache" / "pbr_xval"


def write_obj(vertices: np.ndarray, faces: np.ndarray, tag: str) -> Path:
    """An OBJ file for a triangle mesh in the cache, named by its content, written atomically.

    Parameters
    ----------
    vertices : (n, 3) float, m.
    faces : (m, 3) int.
    """
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    f = np.ascontiguousarray(faces, dtype=np.int64)
    h = hashlib.sha256(v.tobytes())
    h.update(f.tobytes())
    path = cache_dir() / "obj" / f"{tag}_{h.hexdigest()[:24]}.obj"
    if not path.exists():
        from pbr_xval.atomic import write_text_atomic

        lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in v.tolist()]
        lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in f.tolist()]
        write_text_atomic(path, "\n".join(lines) + "\n")
    return path


def collision_parts(
    scene: Scene, choice: str, coacd_threshold: float | None = None, coacd_seed: int = 0
) -> tuple[str, list[tuple[np.ndarray, np.ndarray]]]:
    """Resolve an adapter's ``collision`` setting against the scene compiler's choice.

    ``"auto"`` follows ``scene.collision`` (chosen and recorded by the compiler from the
    scenario's ``[model]``). Returns the kind and, for mesh kinds, the parts as
    [(vertices (n, 3) m, faces (m, 3) int)] in the scene frame; primitive kinds return [].
    """
    if choice not in COLLISION_CHOICES:
        raise ValueError(f"collision {choice!r}; expected one of {COLLISION_CHOICES}")
    sc = scene.collision
    kind = sc["kind"] if choice == "auto" else choice
    rock = scene.rock
    if kind == "primitive" and rock.primitive is None:
        kind = "hull"
    if kind == "boxes" and rock.box_parts is None:
        kind = "hull"
    if kind in ("primitive", "boxes"):
        return kind, []
    if (
        kind == sc["kind"]
        and "parts" in sc
        and (kind != "coacd" or coacd_threshold in (None, sc.get("threshold")))
    ):
        return kind, list(sc["parts"])
    if kind == "hull":
        from pbr_xval.scene import rock_hull

        hull = rock_hull(rock.mesh)  # memoised on the mesh's bytes (ensemble members share it)
        return kind, [(np.asarray(hull.vertices, float), np.asarray(hull.faces, np.int64))]
    if kind == "mesh":
        return kind, [(np.asarray(rock.mesh.vertices, float), np.asarray(rock.mesh.faces, np.int64))]
    if kind == "coacd":
        from pbr_xval.geometry.decompose import convex_parts

        parts = convex_parts(rock.mesh, threshold=coacd_threshold or 0.05, seed=coacd_seed)
        return kind, [(np.asarray(p.vertices, float), np.asarray(p.faces, np.int64)) for p in parts]
    from pbr_xval.geometry.reduce import decimate_keep_base

    size = float(np.ptp(rock.mesh.vertices))
    dec = decimate_keep_base(rock.mesh, size / 20, 0.02 * float(np.ptp(rock.mesh.vertices[:, 2])))
    return kind, [(np.asarray(dec.vertices, float), np.asarray(dec.faces, np.int64))]
