#!/usr/bin/env bash
# RUSTC_WRAPPER of scripts/fuzz.sh: SanitizerCoverage (as cargo-fuzz sets it, on stable) for
# mapbench's own crates and the fuzz targets only. The other dependencies stay exactly as the
# main workspace's `cargo build --release` builds them, so that build's artifacts in target/
# are reused (faer alone takes minutes). fuzz/Cargo.toml gives our crates a profile of their
# own (debug assertions, overflow checks), so their instrumented builds never replace the
# plain ones.
rustc="$1"
shift
case "${CARGO_PKG_NAME:-}" in
  mapbench | mapbench-solvers | mapbench-fuzz)
    # not build scripts: they run at build time, without libFuzzer
    case " $* " in
      *" --crate-name build_script_"*) ;;
      *)
        exec "$rustc" "$@" -Cpasses=sancov-module -Cllvm-args=-sanitizer-coverage-level=4 \
          -Cllvm-args=-sanitizer-coverage-inline-8bit-counters -Cllvm-args=-sanitizer-coverage-pc-table \
          -Cllvm-args=-sanitizer-coverage-trace-compares --cfg fuzzing
        ;;
    esac
    ;;
esac
exec "$rustc" "$@"
