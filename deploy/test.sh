#!/usr/bin/env bash
# The test command: installs (or checks) what the tests need beyond Rust, then runs every
# test of the workspace (unit, the paper's numbers, end-to-end with real processes).
#   deploy/test.sh [ARGS...]     ARGS go to `cargo test --workspace --release` (e.g. `--test view`)
#   deploy/test.sh --python      only the Python package's tests (python/tests/)
# Without ARGS it runs the cargo tests, then the Python package's: a virtual environment of
# its own (target/python-venv), the package installed from python/ (maturin builds the
# extension module), and the pip packages its tests need (pytest, xarray, netCDF4,
# compliance-checker, matplotlib), from PyPI.
#
# Needs, besides a Rust toolchain >= 1.89:
#   chromium, chromedriver  the viewer's browser tests (tests/tests/view.rs); Debian: chromium, chromium-driver
#   node                    the viewer's tick unit tests (view/tests/ticks_js.rs);  Debian: nodejs
#   ip                      network namespaces of a mission over hosts (tests/tests/hosts*.rs); Debian: iproute2
#   useradd, runuser        a second local user (tests/tests/hygiene.rs); Debian: passwd, util-linux
#   tcpdump                 a capture of the network between hosts (tests/tests/hosts*.rs); Debian: tcpdump
#   python3 (>= 3.11, venv) the Python package and its tests (python/); Debian: python3-venv
#   root                    those namespaces (tests/tests/hosts*.rs) and that user
# Missing ones are installed with apt-get when this runs as root (or with sudo); otherwise it
# stops before any test, naming each one missing.
set -euo pipefail
cd "$(dirname "$0")/.."

if ! command -v cargo >/dev/null 2>&1; then
  echo "deploy/test.sh: cargo not found: install Rust (rustup) >= 1.89" >&2
  exit 1
fi

# command → Debian package, for each tool a test needs.
declare -A package=([chromium]=chromium [chromedriver]=chromium-driver [node]=nodejs [ip]=iproute2 [useradd]=passwd [runuser]=util-linux [tcpdump]=tcpdump [python3]=python3-venv)
missing=()
for tool in chromium chromedriver node ip useradd runuser tcpdump; do
  command -v "$tool" >/dev/null 2>&1 || missing+=("$tool")
done
# A Python 3.11 or newer that can make a virtual environment (Debian splits venv off).
python_ok() {
  command -v python3 >/dev/null 2>&1 \
    && python3 -c 'import sys, venv, ensurepip; sys.exit(sys.version_info < (3, 11))' 2>/dev/null
}
python_ok || missing+=(python3)

if [[ ${#missing[@]} -gt 0 ]]; then
  pkgs=()
  for tool in "${missing[@]}"; do pkgs+=("${package[$tool]}"); done
  as_root=()
  if [[ $(id -u) -ne 0 ]] && command -v sudo >/dev/null 2>&1 && sudo -n true 2>/dev/null; then
    as_root=(sudo -n)
  fi
  if command -v apt-get >/dev/null 2>&1 && { [[ $(id -u) -eq 0 ]] || [[ ${#as_root[@]} -gt 0 ]]; }; then
    echo "== installing what the tests need: ${pkgs[*]}"
    "${as_root[@]}" apt-get update -q >/dev/null
    DEBIAN_FRONTEND=noninteractive "${as_root[@]}" apt-get install -y -q "${pkgs[@]}" >/dev/null
  fi
  still=()
  for tool in "${missing[@]}"; do
    if [[ $tool == python3 ]]; then
      python_ok || still+=("python3 >= 3.11 with venv (Debian package ${package[$tool]})")
    else
      command -v "$tool" >/dev/null 2>&1 || still+=("$tool (Debian package ${package[$tool]})")
    fi
  done
  if [[ ${#still[@]} -gt 0 ]]; then
    echo "deploy/test.sh: the tests need what is missing here and could not be installed" >&2
    echo "(no apt-get, or neither root nor passwordless sudo):" >&2
    printf '  %s\n' "${still[@]}" >&2
    exit 1
  fi
fi

# The Python package's tests: after the cargo tests (they use target/release/vbap).
python_tests() {
  local venv="${CARGO_TARGET_DIR:-target}/python-venv"
  echo "== Python: the package (python/) and its tests, in $venv"
  [[ -x $venv/bin/python ]] || python3 -m venv "$venv"
  "$venv/bin/python" -m pip install -q --disable-pip-version-check "./python[test]"
  "$venv/bin/python" -m pytest -q -p no:cacheprovider python/tests
}

if [[ ${1:-} == --python ]]; then
  cargo build --release --quiet --bin vbap
  python_tests
  exit 0
fi

if [[ $(id -u) -ne 0 && $# -eq 0 ]]; then
  echo "deploy/test.sh: tests/tests/hosts.rs and hosts_faults.rs make network namespaces and need root;" >&2
  echo "run this as root (CI does), or run a part of the tests: deploy/test.sh --test missions" >&2
  exit 1
fi

echo "== tests: cargo test --workspace --release $*"
cargo test --workspace --release "$@"
if [[ $# -eq 0 ]]; then
  python_tests
fi
