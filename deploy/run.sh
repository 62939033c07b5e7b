#!/usr/bin/env bash
# Builds vbap (release; quiet when up to date) and runs `vbap run` on a mission.
#   deploy/run.sh [MISSION.toml] [ARGS...]     default mission: deploy/missions/glider.toml
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/.." && pwd)"
cargo build --release --quiet --manifest-path "$root/Cargo.toml" \
  -p vbap-cli -p field_server -p vehicle_agent -p coordinator
target="${CARGO_TARGET_DIR:-$root/target}"
mission="$here/missions/glider.toml"
if [[ $# -gt 0 && "$1" != --* ]]; then
  mission="$1"
  shift
fi
exec "$target/release/vbap" run "$mission" "$@"
