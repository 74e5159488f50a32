#![no_main]
//! cargo fuzz target `mcap` (see fuzz/README.md); the checks live in `pgm_fuzz::mcap`.

libfuzzer_sys::fuzz_target!(|data: &[u8]| pgm_fuzz::mcap(data));
