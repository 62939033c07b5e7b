#!/usr/bin/env bash
# Makes the README's pictures again, with the project's own tools and headless Chromium
# (Debian's `chromium`, which deploy/test.sh installs):
#   formation.png  plot.svg of `vbap sim deploy/missions/glider.toml` (the default mission)
#   viewer.png     the page of `vbap view` on that run
#   docs/pictures/regenerate.sh
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
command -v chromium >/dev/null || { echo "regenerate.sh: needs chromium (Debian: chromium)" >&2; exit 1; }
cargo build --release --quiet --manifest-path "$root/Cargo.toml" -p vbap-cli
vbap="${CARGO_TARGET_DIR:-$root/target}/release/vbap"
work="$(mktemp -d /tmp/vbap-pictures-XXXXXX)"
viewer=""
cleanup() {
  [[ -n "$viewer" ]] && kill "$viewer" 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT

shot() { # shot URL PNG WIDTH HEIGHT
  chromium --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
    --disable-background-networking --disable-component-update --disable-sync \
    --hide-scrollbars --user-data-dir="$work/profile" --window-size="$3,$4" \
    --virtual-time-budget=10000 --screenshot="$2" "$1" >/dev/null 2>&1
  [[ -s "$2" ]] || { echo "regenerate.sh: chromium wrote no $2" >&2; exit 1; }
}

"$vbap" sim "$root/deploy/missions/glider.toml" --out "$work/run" --quiet
svg="$work/run/plot.svg"
width=$(grep -o -m1 'width="[0-9]*"' "$svg" | tr -dc 0-9)
height=$(grep -o -m1 'height="[0-9]*"' "$svg" | tr -dc 0-9)
shot "file://$svg" "$here/formation.png" "$width" "$height"

"$vbap" view "$work/run" --addr 127.0.0.1:0 >"$work/view.out" 2>&1 &
viewer=$!
for _ in $(seq 100); do
  url=$(grep -o -m1 'http://127.0.0.1:[0-9]*/' "$work/view.out" || true)
  [[ -n "$url" ]] && break
  sleep 0.1
done
[[ -n "$url" ]] || { echo "regenerate.sh: vbap view printed no URL: $(cat "$work/view.out")" >&2; exit 1; }
# The middle of the run (t = 14 h): the formation on its way, the panels half drawn.
shot "${url}?t=50400" "$here/viewer.png" 1400 800
echo "wrote $here/formation.png and $here/viewer.png"
