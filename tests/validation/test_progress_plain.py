"""Progress off a terminal (issue 23): a ``validate`` whose output is a pipe prints plain lines —
done / total, failures and the ETA — instead of a progress bar that draws nothing until the end."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

RAW = ["--highpass", "0", "--lowpass", "0", "--detrend", "none", "--resample", "0"]


def test_validate_prints_plain_progress_lines_into_a_pipe(
    box_campaign_files: tuple[Path, Path, list[int]], tmp_path: Path
) -> None:
    csv, scn, _ = box_campaign_files
    cmd = [sys.executable, "-c", "from pbr_xval.cli import app; app()", "validate", str(csv), "--specimen", "1", "--scenario", str(scn),
           "--engine", "housner", "--out", str(tmp_path / "r"), "--tail", "2", "--workers", "1", *RAW]  # fmt: skip
    # a narrow console: a plain progress line is never hard-wrapped (rich wraps a non-terminal console at 80
    # columns, which once split ``… ETA 710 s`` over two lines of a log file)
    env = dict(os.environ, COLUMNS="30")
    res = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=300)  # stdout, stderr: pipes
    assert res.returncode == 0, res.stderr
    text = res.stdout + res.stderr
    assert "validate: 6 chunks, 0 already in the store, 6 to run" in text
    lines = re.findall(
        r"validate: (\d+)/6 done, (\d+) chunks failed, (\d+) runs not ok, \d+ s, (ETA \d+ s|finished)", text
    )
    # six tests: each is more than 5 % of the campaign, so every one is a line; the last says finished
    assert [int(x[0]) for x in lines] == [1, 2, 3, 4, 5, 6]
    assert all(x[1] == "0" and x[2] == "0" for x in lines)
    assert lines[-1][3] == "finished" and lines[0][3].startswith("ETA")
    assert "━" not in text  # no bar characters in a pipe
    # nor is any other line (every command's consoles soft-wrap): the closing line is whole
    assert re.search(
        r"^wrote \S+index\.html, outcomes\.csv, scores\.csv, bands\.csv \([\d.]+ s\)$", text, re.M
    )
