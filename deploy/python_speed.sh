#!/usr/bin/env bash
# The cost of vbap.sim from Python against the `vbap sim` command, on the same mission,
# measured side by side (issue goal: Python ≤ 1.1 × the command).
#   deploy/python_speed.sh [MISSION.toml] [REPS]     default: deploy/missions/glider_iridium.toml, 7
# Builds vbap and installs the package into target/python-venv (as deploy/test.sh does),
# then alternates the two REPS times: the command's wall time (process start to exit) and
# the Python call's (vbap.sim in an interpreter that has imported vbap). Prints the medians
# and their ratio, and checks that every pair of run directories is the same run.
set -euo pipefail
cd "$(dirname "$0")/.."
mission="${1:-deploy/missions/glider_iridium.toml}"
reps="${2:-7}"
cargo build --release --quiet --bin vbap
venv="${CARGO_TARGET_DIR:-target}/python-venv"
[[ -x $venv/bin/python ]] || python3 -m venv "$venv"
"$venv/bin/python" -m pip install -q --disable-pip-version-check ./python
"$venv/bin/python" - "$mission" "$reps" <<'PY'
import statistics, subprocess, sys, tempfile, time
from pathlib import Path
import vbap

mission, reps = sys.argv[1], int(sys.argv[2])
exe = Path("target/release/vbap").resolve()
cli, py = [], []
with tempfile.TemporaryDirectory() as tmp:
    for i in range(reps):
        a, b = Path(tmp) / f"cli{i}", Path(tmp) / f"py{i}"
        t = time.perf_counter()
        subprocess.run([exe, "sim", mission, "--quiet", "--out", a], check=True, capture_output=True)
        cli.append(time.perf_counter() - t)
        t = time.perf_counter()
        vbap.sim(mission, out=b)
        py.append(time.perf_counter() - t)
        same = subprocess.run([exe, "compare", a, b], capture_output=True)
        if same.returncode != 0:
            sys.exit(f"run {i}: Python and the command wrote different runs:\n{same.stdout.decode()}")
c, p = statistics.median(cli), statistics.median(py)
print(f"{mission}, {reps} runs each, alternating")
print(f"  vbap sim (command)   median {c:.3f} s  (runs {min(cli):.3f}-{max(cli):.3f})")
print(f"  vbap.sim (Python)    median {p:.3f} s  (runs {min(py):.3f}-{max(py):.3f})")
print(f"  Python / command     = {p / c:.2f}  (goal <= 1.1: {'met' if p / c <= 1.1 else 'MISSED'})")
PY
