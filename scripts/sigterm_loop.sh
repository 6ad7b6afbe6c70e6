#!/usr/bin/env bash
# SIGTERM (what Slurm sends at a job's time limit and on scancel) at a batch's METIS
# orderings, N times: every try must exit 143 with the report written and meta.json saying
# `interrupted: true`. Prints one line per try and the totals; exit 1 when any try failed.
#
#   scripts/sigterm_loop.sh [TRIES] [BINARY]     # default 100, target/release/mapbench
#
# The batch reproduces the crash it guards against: a 9-run config (three generated meshes of 10k-50k
# vertices, three solvers each) run as `--shard 2/3 --jobs 1`, so each of its three runs is
# on a new mesh and starts with a fresh METIS ordering; the signal goes out right after the
# first run's `[1/3]` line plus a delay: 300, 325, ..., 775 ms in turn, over the second run's
# mesh, Tutte map and METIS ordering (bumpy_50k's, which start a few tenths of a second after
# that line on a 2-core machine) and into its iterations. DELAY_MS=<ms> sends every signal at that one delay.
set -uo pipefail
tries=${1:-100}
bin=${2:-target/release/mapbench}
fixed_delay=${DELAY_MS:-}
root=$(cd "$(dirname "$0")/.." && pwd)
case "$bin" in /*) ;; *) bin="$root/$bin" ;; esac
[ -x "$bin" ] || { echo "no binary $bin (cargo build --release first)" >&2; exit 2; }

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cat >"$work/sig.toml" <<EOF
name = "sigterm"
task = "param"
registry = "$root/datasets.toml"
datasets = ["bumpy_1k", "bumpy_50k", "bumpy_5k"]
energies = ["sd"]
solvers = ["kp-newton", "fp-newton-4x4", "cm"]
[stop]
max_iters = 3
EOF

crashed=0; wrong=0; ok=0
for i in $(seq 1 "$tries"); do
  out="$work/out$i"
  fifo="$work/err$i"
  mkfifo "$fifo"
  "$bin" run "$work/sig.toml" --out "$out" --shard 2/3 --jobs 1 --no-history 2>"$fifo" &
  pid=$!
  sent=0
  while IFS= read -r line; do
    echo "$line" >>"$work/log$i"
    if [ $sent = 0 ] && [[ "$line" == "[1/3]"* ]]; then
      delay_ms=${fixed_delay:-$((300 + 25 * ((i - 1) % 20)))}
      sleep "$(printf '%d.%03d' $((delay_ms / 1000)) $((delay_ms % 1000)))"
      kill -TERM "$pid" 2>/dev/null
      sent=1
    fi
  done <"$fifo"
  wait "$pid"
  rc=$?
  rm -f "$fifo"
  interrupted=$(grep -o '"interrupted": [a-z]*' "$out/meta.json" 2>/dev/null | head -1 | awk '{print $2}')
  report=no
  [ -s "$out/index.html" ] && report=yes
  if [ "$sent" = 0 ]; then
    verdict="no [1/3] line (rc $rc)"
    wrong=$((wrong + 1))
  elif [ "$rc" -ge 132 ] && [ "$rc" != 143 ]; then
    verdict="CRASH"
    crashed=$((crashed + 1))
  elif [ "$rc" = 143 ] && [ "$report" = yes ] && [ "$interrupted" = true ]; then
    verdict="ok"
    ok=$((ok + 1))
  else
    verdict="WRONG"
    wrong=$((wrong + 1))
  fi
  echo "try $i (signal ${delay_ms:-?} ms after [1/3]): exit $rc, report $report, interrupted ${interrupted:-?}: $verdict"
  rm -rf "$out"
done
echo "tries $tries: $ok clean stops (exit 143, report, interrupted: true), $crashed crashes, $wrong other"
[ "$crashed" = 0 ] && [ "$wrong" = 0 ]
