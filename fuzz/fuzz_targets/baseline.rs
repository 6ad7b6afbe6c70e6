#![no_main]
//! Fuzz target: one input through `mapbench::fuzzing::baseline` (the same code the regression
//! tests run on `fuzz/regressions/baseline/`).

#[global_allocator]
static ALLOC: mapbench_fuzz::LimitedAlloc = mapbench_fuzz::LimitedAlloc;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let _ = mapbench::fuzzing::baseline(data);
});
