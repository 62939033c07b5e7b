"""The notebook-style example runs as a script and draws its plot."""

from __future__ import annotations

import subprocess
import sys

from conftest import ROOT


def test_the_loss_sweep_example_plots_the_success_rate(tmp_path):
    script = ROOT / "examples" / "python" / "sweep_loss.py"
    done = subprocess.run(
        [sys.executable, str(script), "--seeds", "2", "--out", str(tmp_path)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    picture = tmp_path / "success_rate.png"
    assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "success rate by loss: {0.0: " in done.stdout
    # Without loss every seed of the shipped mission converges.
    assert "{0.0: np.float64(1.0)" in done.stdout or "{0.0: 1.0" in done.stdout
