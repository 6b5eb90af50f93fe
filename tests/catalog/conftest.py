from __future__ import annotations

from pathlib import Path

import pytest

HERE = Path(__file__).parent

TINY = """
name = "tiny"
seed = 11
duration = 1.5
engines = ["housner"]
chunk_size = 2

[settings.housner]
rtol = 1e-8
atol = 1e-10

[[rock]]
id = "blk"
shape = "box"
half_extents = [0.2, 0.2, 0.6]
density = 2400.0
friction = 2.0

[[rock]]
id = "squat"
shape = "box"
half_extents = [0.3, 0.3, 0.6]
density = 2600.0
friction_min = 0.8
friction_max = 1.2
{extra_rocks}
[motions]
[[motions.pulse]]
type = "half_sine"
amplitude = [3.0, 9.0]
frequency = [1.0, 2.0]

[choose]
rocks = 2
motions = 4
engines = ["housner", "mujoco"]
timesteps = [5e-3]
profiles = ["faithful"]
reference_engine = "housner"
"""


def write_catalog(dirpath: Path, extra_rocks: str = "", **repl: str) -> Path:
    text = TINY.replace("{extra_rocks}", extra_rocks)
    for k, v in repl.items():
        text = text.replace(k, v)
    p = dirpath / "tiny.toml"
    p.write_text(text)
    return p


@pytest.fixture
def tiny_catalog(tmp_path: Path) -> Path:
    return write_catalog(tmp_path)
