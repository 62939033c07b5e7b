#!/usr/bin/env bash
# The test command: installs (or checks) what the tests need beyond Rust, then runs every
# test of the workspace (unit, the paper's numbers, end-to-end with real processes).
#   deploy/test.sh [ARGS...]     ARGS go to `cargo test --workspace --release` (e.g. `--test view`)
#
# Needs, besides a Rust toolchain >= 1.89:
#   chromium, chromedriver  the viewer's browser tests (tests/tests/view.rs); Debian: chromium, chromium-driver
#   node                    the viewer's tick unit tests (view/tests/ticks_js.rs);  Debian: nodejs
#   ip                      network namespaces of a mission over hosts (tests/tests/hosts*.rs); Debian: iproute2
#   useradd, runuser        a second local user (tests/tests/hygiene.rs); Debian: passwd, util-linux
#   tcpdump                 a capture of the network between hosts (tests/tests/hosts*.rs); Debian: tcpdump
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
declare -A package=([chromium]=chromium [chromedriver]=chromium-driver [node]=nodejs [ip]=iproute2 [useradd]=passwd [runuser]=util-linux [tcpdump]=tcpdump)
missing=()
for tool in chromium chromedriver node ip useradd runuser tcpdump; do
  command -v "$tool" >/dev/null 2>&1 || missing+=("$tool")
done

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
    command -v "$tool" >/dev/null 2>&1 || still+=("$tool (Debian package ${package[$tool]})")
  done
  if [[ ${#still[@]} -gt 0 ]]; then
    echo "deploy/test.sh: the tests need what is missing here and could not be installed" >&2
    echo "(no apt-get, or neither root nor passwordless sudo):" >&2
    printf '  %s\n' "${still[@]}" >&2
    exit 1
  fi
fi

if [[ $(id -u) -ne 0 && $# -eq 0 ]]; then
  echo "deploy/test.sh: tests/tests/hosts.rs and hosts_faults.rs make network namespaces and need root;" >&2
  echo "run this as root (CI does), or run a part of the tests: deploy/test.sh --test missions" >&2
  exit 1
fi

echo "== tests: cargo test --workspace --release $*"
exec cargo test --workspace --release "$@"
