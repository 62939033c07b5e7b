#!/usr/bin/env bash
# Does an in-process `vbap batch` use both cores? Runs the same study (a 3 x 3 sweep of
# glider_surfacing's link loss and surfacing period x SEEDS seeds, --in-process) at
# --jobs 1 and at --jobs 2, back to back, and prints both wall times, the CPU each used and
# the ratio (the goal: >= 1.7 on 2 cores). The load average is printed before and after
# each: on a shared machine measure when it is calm.
#   deploy/batch_scaling.sh [SEEDS] [OUT]     SEEDS default 10; OUT default a temp dir
set -euo pipefail
seeds="${1:-10}"
root="$(cd "$(dirname "$0")/.." && pwd)"
out="${2:-$(mktemp -d -t vbap-scaling-XXXXXX)}"
vbap="$root/target/release/vbap"
[[ -x "$vbap" ]] || { echo "build first: cargo build --release" >&2; exit 2; }
declare -A wall
for jobs in 1 2; do
  dir="$out/jobs$jobs"
  rm -rf "$dir"
  echo "jobs $jobs: load before $(cut -d' ' -f1-3 /proc/loadavg)" >&2
  start=$(date +%s.%N)
  /usr/bin/env time -f "jobs $jobs: %e s wall, %U s user, %S s sys, %P CPU" \
    "$vbap" batch "$root/deploy/missions/glider_surfacing.toml" --seeds "$seeds" \
    --in-process --jobs "$jobs" --quiet --out "$dir" \
    --sweep links.loss=0.0,0.1,0.2 --sweep links.surfacing_period=3600,7200,14400 \
    > "$dir.json" 2> "$dir.err" || true
  end=$(date +%s.%N)
  wall[$jobs]=$(echo "$end - $start" | bc -l)
  grep -hE "^(jobs|PASS|FAIL|batch of)" "$dir.err" >&2 || true
  echo "jobs $jobs: load after $(cut -d' ' -f1-3 /proc/loadavg)" >&2
done
printf 'wall time: jobs 1 %.1f s, jobs 2 %.1f s; speed-up %.2f x (goal >= 1.7)\n' \
  "${wall[1]}" "${wall[2]}" "$(echo "${wall[1]} / ${wall[2]}" | bc -l)"
