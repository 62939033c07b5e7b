#!/usr/bin/env bash
# Did a change of the code leave the results alone? Builds revision REV in a temporary
# worktree, runs every shipped mission (deploy/missions/*.toml) with `vbap sim` and
# `vbap run` under REV's binaries and under this checkout's, and compares each pair of run
# directories with `vbap compare` (files from mission time byte for byte, summary.json
# without its wall-clock fields). Exit 0 when every pair is the same run.
#   deploy/compare_with.sh REV [OUT]        OUT: where the runs go (default: a temp dir)
# The `run` of a mission with a scheduled SIGKILL is compared without summary.json's
# `messages`: how far the victim read ahead before it died is wall-clock timing.
set -euo pipefail
[[ $# -ge 1 ]] || { echo "usage: $0 REV [OUT]" >&2; exit 2; }
rev="$1"
root="$(cd "$(dirname "$0")/.." && pwd)"
out="${2:-$(mktemp -d -t vbap-compare-XXXXXX)}"
mkdir -p "$out"
old_src="$out/src-$rev"
git -C "$root" worktree add --detach --quiet "$old_src" "$rev"
trap 'git -C "$root" worktree remove --force "$old_src"' EXIT
echo "building $rev and this checkout (release)..." >&2
CARGO_TARGET_DIR="$out/target-old" cargo build --release --quiet --workspace --bins \
  --manifest-path "$old_src/Cargo.toml"
cargo build --release --quiet --workspace --bins --manifest-path "$root/Cargo.toml"
old_bin="$out/target-old/release/vbap"
new_bin="${CARGO_TARGET_DIR:-$root/target}/release/vbap"
status=0
for mission in "$root"/deploy/missions/*.toml; do
  name="$(basename "$mission" .toml)"
  for mode in sim run; do
    "$old_bin" "$mode" "$mission" --out "$out/old/$mode-$name" --quiet >/dev/null
    "$new_bin" "$mode" "$mission" --out "$out/new/$mode-$name" --quiet >/dev/null
    ignore=()
    if [[ $mode == run ]] && grep -q '^kind *= *"kill"' "$mission"; then
      ignore=(--ignore messages)
    fi
    echo "== $mode $name"
    "$new_bin" compare "$out/old/$mode-$name" "$out/new/$mode-$name" "${ignore[@]}" || status=1
  done
done
echo "runs in $out"
exit $status
