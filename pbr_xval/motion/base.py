"""Ground-motion base classes.

A :class:`GroundMotion` is one translational component of base excitation
(horizontal or vertical) in SI units: time in s, acceleration in m/s²,
velocity in m/s, displacement in m.  :class:`Excitation3D` combines a
horizontal component acting along an azimuth with an optional vertical one.

Conventions shared by every motion
----------------------------------
* Before ``t = 0`` the ground is at rest: a = v = d = 0.
* For pulses, a(t) = 0 after :attr:`GroundMotion.duration`; the velocity then
  stays at its residual value and the displacement grows linearly with it.
* :attr:`GroundMotion.breakpoints` lists the times in ``[0, duration]`` where
  a(t) jumps or has a kink, so event-based ODE integrators can restart there.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["Excitation3D", "GroundMotion", "MotionFileError", "ScaledMotion"]

FloatOrArray = float | NDArray[np.float64]


class MotionFileError(ValueError):
    """A ground-motion record file is malformed.

    The message names the file, the line number where one applies, what was
    found and what was expected.

    Parameters
    ----------
    message : str
        What was found and what was expected.
    path : str or os.PathLike, optional
        The offending file.
    line : int, optional
        1-based line number in the file.
    """

    def __init__(self, message: str, path: Any = None, line: int | None = None) -> None:
        self.path = None if path is None else str(path)
        self.line = line
        where = "" if path is None else str(path)
        if line is not None:
            where += f", line {line}"
        super().__init__(f"{where}: {message}" if where else message)


def _evaluate(fn: Callable[[NDArray[np.float64]], NDArray[np.float64]], t: ArrayLike) -> FloatOrArray:
    """Apply a 1-D vectorised kernel to scalar or array time; scalar in, float out."""
    arr = np.asarray(t, dtype=float)
    out = np.asarray(fn(arr.reshape(-1)), dtype=float).reshape(arr.shape)
    return float(out) if arr.ndim == 0 else out


class GroundMotion(ABC):
    """One component of ground motion (abstract).

    Subclasses implement the kernels ``_acceleration``, ``_velocity`` and
    ``_displacement`` on 1-D float arrays of time (s) and the properties
    :attr:`duration` and :meth:`describe`.

    Attributes
    ----------
    name : str
        Human-readable label.
    """

    name: str = "motion"

    # -- kernels ---------------------------------------------------------
    @abstractmethod
    def _acceleration(self, t: NDArray[np.float64]) -> NDArray[np.float64]: ...

    @abstractmethod
    def _velocity(self, t: NDArray[np.float64]) -> NDArray[np.float64]: ...

    @abstractmethod
    def _displacement(self, t: NDArray[np.float64]) -> NDArray[np.float64]: ...

    @property
    @abstractmethod
    def duration(self) -> float:
        """float, s: time after which a pulse is identically zero (record length for records)."""

    @abstractmethod
    def describe(self) -> dict[str, Any]:
        """Parameters as a JSON-serialisable dict (provenance)."""

    # -- public API ------------------------------------------------------
    def acceleration(self, t: ArrayLike) -> FloatOrArray:
        """Ground acceleration.

        Parameters
        ----------
        t : float or (n,) float, s

        Returns
        -------
        float or (n,) float, m/s²
        """
        return _evaluate(self._acceleration, t)

    def velocity(self, t: ArrayLike) -> FloatOrArray:
        """Ground velocity, the exact integral of :meth:`acceleration` from 0.

        Parameters
        ----------
        t : float or (n,) float, s

        Returns
        -------
        float or (n,) float, m/s
        """
        return _evaluate(self._velocity, t)

    def displacement(self, t: ArrayLike) -> FloatOrArray:
        """Ground displacement, the exact integral of :meth:`velocity` from 0.

        Parameters
        ----------
        t : float or (n,) float, s

        Returns
        -------
        float or (n,) float, m
        """
        return _evaluate(self._displacement, t)

    @property
    def breakpoints(self) -> tuple[float, ...]:
        """tuple of float, s: times in ``[0, duration]`` where a(t) is non-smooth (incl. 0 and duration)."""
        return (0.0, float(self.duration))

    def sample(
        self, dt: float, t_end: float | None = None
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Sample the acceleration on the uniform grid ``0, dt, 2 dt, ... <= t_end``.

        Parameters
        ----------
        dt : float, s
            Time step, > 0.
        t_end : float, s, optional
            Last time (inclusive, up to rounding); defaults to :attr:`duration`.

        Returns
        -------
        t : (n,) float, s
        a : (n,) float, m/s²
        """
        if not (np.isfinite(dt) and dt > 0):
            raise ValueError(f"dt must be a positive finite time step in s, got {dt!r}")
        t_end = self.duration if t_end is None else float(t_end)
        if not (np.isfinite(t_end) and t_end >= 0):
            raise ValueError(f"t_end must be a finite time >= 0 s, got {t_end!r}")
        n = int(np.floor(t_end / dt * (1.0 + 1e-12))) + 1
        t = np.arange(n, dtype=np.float64) * float(dt)
        return t, self._acceleration(t)

    def scaled(self, factor: float) -> GroundMotion:
        """Return a copy with a, v and d multiplied by ``factor`` (dimensionless)."""
        return ScaledMotion(self, factor)

    def __repr__(self) -> str:
        params = ", ".join(f"{k}={v!r}" for k, v in self.describe().items() if k != "type")
        return f"{type(self).__name__}({params})"


class ScaledMotion(GroundMotion):
    """Amplitude-scaled view of another motion: a, v, d multiplied by ``factor``.

    Parameters
    ----------
    base : GroundMotion
    factor : float
        Dimensionless, finite (may be negative to flip polarity).
    """

    base: GroundMotion
    factor: float

    def __init__(self, base: GroundMotion, factor: float) -> None:
        factor = float(factor)
        if not np.isfinite(factor):
            raise ValueError(f"factor must be a finite number, got {factor!r}")
        if isinstance(base, ScaledMotion):
            factor = base.factor * factor
            base = base.base
        self.base = base
        self.factor = factor
        self.name = f"{base.name}*{factor:g}"

    def _acceleration(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        return self.factor * self.base._acceleration(t)

    def _velocity(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        return self.factor * self.base._velocity(t)

    def _displacement(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        return self.factor * self.base._displacement(t)

    @property
    def duration(self) -> float:
        """float, s: the base motion's duration (scaling does not change it)."""
        return self.base.duration

    @property
    def breakpoints(self) -> tuple[float, ...]:
        """tuple of float, s: the base motion's breakpoints."""
        return self.base.breakpoints

    @property
    def pga(self) -> float:
        """float, m/s²: exact peak |a|, available when the base motion has one."""
        return abs(self.factor) * self.base.pga  # type: ignore[attr-defined]

    @property
    def pgv(self) -> float:
        """float, m/s: exact peak |v|, available when the base motion has one."""
        return abs(self.factor) * self.base.pgv  # type: ignore[attr-defined]

    def describe(self) -> dict[str, Any]:
        """Parameters as a JSON-serialisable dict: the factor and the base motion's description."""
        return {
            "type": "ScaledMotion",
            "name": self.name,
            "factor": self.factor,
            "base": self.base.describe(),
        }


class Excitation3D:
    """Three-component base excitation (x, y horizontal; z up), SI.

    Parameters
    ----------
    horizontal : GroundMotion
        Horizontal component, acting along the unit vector (cos az, sin az, 0).
    azimuth : float, rad
        Direction of the horizontal motion, measured from +x toward +y.
    vertical : GroundMotion, optional
        Vertical component (positive up). ``None`` means no vertical motion.
    """

    def __init__(
        self, horizontal: GroundMotion, azimuth: float = 0.0, vertical: GroundMotion | None = None
    ) -> None:
        if not np.isfinite(azimuth):
            raise ValueError(f"azimuth must be a finite angle in rad, got {azimuth!r}")
        self.horizontal = horizontal
        self.azimuth = float(azimuth)
        self.vertical = vertical
        self._dir = np.array([np.cos(self.azimuth), np.sin(self.azimuth)])

    def _combine(self, kind: str, t: ArrayLike) -> NDArray[np.float64]:
        arr = np.asarray(t, dtype=float)
        h = np.asarray(getattr(self.horizontal, kind)(arr), dtype=float)
        z = (
            np.zeros_like(h)
            if self.vertical is None
            else np.asarray(getattr(self.vertical, kind)(arr), dtype=float)
        )
        return np.stack([h * self._dir[0], h * self._dir[1], z], axis=-1)

    def acceleration(self, t: ArrayLike) -> NDArray[np.float64]:
        """Acceleration vector; t : float or (n,) s -> (3,) or (n, 3) m/s²."""
        return self._combine("acceleration", t)

    def velocity(self, t: ArrayLike) -> NDArray[np.float64]:
        """Velocity vector; t : float or (n,) s -> (3,) or (n, 3) m/s."""
        return self._combine("velocity", t)

    def displacement(self, t: ArrayLike) -> NDArray[np.float64]:
        """Displacement vector; t : float or (n,) s -> (3,) or (n, 3) m."""
        return self._combine("displacement", t)

    @property
    def components(self) -> tuple[GroundMotion, ...]:
        """The horizontal and (if present) vertical components."""
        return (self.horizontal,) if self.vertical is None else (self.horizontal, self.vertical)

    @property
    def duration(self) -> float:
        """float, s: the longest component duration."""
        return max(c.duration for c in self.components)

    @property
    def breakpoints(self) -> tuple[float, ...]:
        """tuple of float, s: sorted union of the components' breakpoints."""
        return tuple(sorted({float(b) for c in self.components for b in c.breakpoints}))

    def describe(self) -> dict[str, Any]:
        """JSON-serialisable parameters."""
        return {
            "type": "Excitation3D",
            "azimuth": self.azimuth,
            "horizontal": self.horizontal.describe(),
            "vertical": None if self.vertical is None else self.vertical.describe(),
        }
