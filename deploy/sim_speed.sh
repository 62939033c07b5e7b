#!/usr/bin/env bash
# How fast is `vbap sim` against revision REV, and are its files the same? Builds REV's
# `vbap` in a temporary worktree and this checkout's, runs `vbap sim` of the same missions
# with both, alternating (old, new, old, new, ...) REPS times each, and prints the ticks per
# second of each (the median over the repetitions; ticks ÷ summary.json's wall_time_s, the
# simulation loop without the pictures drawn after it) and the ratio new / old. Then
# compares the run directories of the first repetition pair by pair with `vbap compare`
# (files from mission time byte for byte, summary.json without its wall-clock fields).
# Exit 0 when every pair is the same run.
#   deploy/sim_speed.sh REV [OUT] [REPS]   OUT: where the runs go (default: a temp dir);
#                                          REPS: repetitions of each side (default 5)
# Missions: the paper's (deploy/missions/paper.toml) at N = 16 (500 s, 10 000 ticks) and
# N = 256 (20 s, 400 ticks) on a polygon with the paper square's edge (as `vbap bench`
# flies it), and the shipped glider mission deploy/missions/glider_surfacing.toml.
# On a shared machine the figures move with the load: compare the ratio, and run it twice.
set -euo pipefail
[[ $# -ge 1 ]] || { echo "usage: $0 REV [OUT] [REPS]" >&2; exit 2; }
rev="$1"
root="$(cd "$(dirname "$0")/.." && pwd)"
out="${2:-$(mktemp -d -t vbap-sim-speed-XXXXXX)}"
reps="${3:-5}"
mkdir -p "$out"
old_src="$out/src-$rev"
git -C "$root" worktree add --detach --quiet "$old_src" "$rev"
trap 'git -C "$root" worktree remove --force "$old_src"' EXIT
echo "building $rev and this checkout (release, vbap only)..." >&2
CARGO_TARGET_DIR="$out/target-old" cargo build --release --quiet --bin vbap \
  --manifest-path "$old_src/Cargo.toml"
cargo build --release --quiet --bin vbap --manifest-path "$root/Cargo.toml"
old_bin="$out/target-old/release/vbap"
new_bin="${CARGO_TARGET_DIR:-$root/target}/release/vbap"

# The polygon radius whose edge is the paper square's (radius 1.229), for n vehicles.
radius() { awk -v n="$1" 'BEGIN { pi = atan2(0, -1); e = 2 * 1.229 * sin(pi / 4); printf "%.12g", e / (2 * sin(pi / n)) }'; }
paper="$root/deploy/missions/paper.toml"
names=(paper-n16 paper-n256 glider_surfacing)
declare -A files args
files[paper-n16]="$paper"
args[paper-n16]="--set vehicles.count=16 --set formation.radius=$(radius 16) --duration 500"
files[paper-n256]="$paper"
args[paper-n256]="--set vehicles.count=256 --set formation.radius=$(radius 256) --duration 20"
files[glider_surfacing]="$root/deploy/missions/glider_surfacing.toml"
args[glider_surfacing]=""

# Ticks per second of the run directory $1 (from its summary.json).
rate() {
  local s="$1/summary.json" ticks wall
  ticks="$(sed -n 's/^ *"ticks": *\([0-9]*\),*$/\1/p' "$s")"
  wall="$(sed -n 's/^ *"wall_time_s": *\([0-9.eE+-]*\),*$/\1/p' "$s")"
  awk -v t="$ticks" -v w="$wall" 'BEGIN { printf "%.1f", t / w }'
}
median() { tr ' ' '\n' | grep -v '^$' | sort -g | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }

status=0
printf '%-18s %12s %12s %8s   %s\n' mission "old ticks/s" "new ticks/s" new/old "runs (old | new)"
for name in "${names[@]}"; do
  old_rates=() new_rates=()
  for ((i = 1; i <= reps; i++)); do
    for side in old new; do
      bin="$old_bin"; [[ $side == new ]] && bin="$new_bin"
      dir="$out/$side/$name-$i"
      rm -rf "$dir"
      # shellcheck disable=SC2086
      "$bin" sim "${files[$name]}" ${args[$name]} --out "$dir" --quiet >/dev/null 2>"$out/$side-$name-$i.err"
      r="$(rate "$dir")"
      if [[ $side == old ]]; then old_rates+=("$r"); else new_rates+=("$r"); fi
      # Keep the first pair for the comparison; later ones only for their speed.
      [[ $i -gt 1 ]] && rm -rf "$dir"
    done
  done
  o="$(echo "${old_rates[*]}" | median)"
  n="$(echo "${new_rates[*]}" | median)"
  printf '%-18s %12.1f %12.1f %8.2f   %s | %s\n' "$name" "$o" "$n" "$(awk -v o="$o" -v n="$n" 'BEGIN { print n / o }')" \
    "${old_rates[*]}" "${new_rates[*]}"
done
for name in "${names[@]}"; do
  echo "== $name"
  "$new_bin" compare "$out/old/$name-1" "$out/new/$name-1" || status=1
done
echo "runs in $out"
exit $status
