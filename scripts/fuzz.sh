#!/usr/bin/env bash
# Build the fuzz targets of fuzz/ with stable Rust and run each one (docs/src/design/testing.md).
#   scripts/fuzz.sh [RUNS] [TARGET...]   RUNS inputs per target (default 1000000), all targets
#   FUZZ_SECONDS=S scripts/fuzz.sh ...     also stop each target after S seconds (the CI smoke run)
# libFuzzer comes from the libfuzzer-sys crate (its C++ source, built with cc); the coverage
# instrumentation is LLVM's SanitizerCoverage, switched on with stable -C flags as cargo-fuzz
# does it (scripts/fuzz-rustc.sh), without a sanitizer (that would need nightly). Limits per input: 10 s, 1 GiB RSS, no
# single allocation over 1 GiB (fuzz/src/lib.rs). New inputs go to fuzz/corpus/<target>/,
# crashes to fuzz/artifacts/<target>/ (both ignored by git); fuzz/seeds/<target>/ and
# fuzz/regressions/<target>/ are read, never written. Exits non-zero on the first finding.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root/fuzz"

runs="${1:-1000000}"
[ $# -gt 0 ] && shift
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(obj config registry handles baseline)

# Built into the main target/ with its release profile, so the dependencies a plain
# `cargo build --release` compiled are reused (not those of `cargo test --workspace`, whose
# dev-dependencies turn on more features); scripts/fuzz-rustc.sh instruments only our crates.
export CARGO_TARGET_DIR="$root/target"
export RUSTC_WRAPPER="$root/scripts/fuzz-rustc.sh"
cargo build --release --locked --bins
bin="$CARGO_TARGET_DIR/release"

mkdir -p logs
summary=()
for t in "${targets[@]}"; do
  mkdir -p "corpus/$t" "artifacts/$t" "regressions/$t"
  args=(-runs="$runs" -rss_limit_mb=1024 -malloc_limit_mb=1024 -timeout=10
    -artifact_prefix="artifacts/$t/" -print_final_stats=1)
  [ -z "${FUZZ_SECONDS:-}" ] || args+=(-max_total_time="$FUZZ_SECONDS")
  echo "== fuzz $t: ${args[*]}"
  start=$(date +%s)
  status=0
  "$bin/fuzz_$t" "${args[@]}" "corpus/$t" "seeds/$t" "regressions/$t" 2>"logs/$t.log" || status=$?
  secs=$(($(date +%s) - start))
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "logs/$t.log" | tail -1)
  line="$t: ${execs:-?} inputs in ${secs} s, exit $status"
  echo "$line"
  summary+=("$line")
  if [ "$status" != 0 ]; then
    tail -40 "logs/$t.log"
    echo "fuzz $t found a problem: the input is in fuzz/artifacts/$t/ (log: fuzz/logs/$t.log)"
    exit 1
  fi
done
echo "== fuzz summary ($(date -u +%Y-%m-%d))"
printf '%s\n' "${summary[@]}"
