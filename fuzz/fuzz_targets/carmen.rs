#![no_main]
//! cargo fuzz target `carmen` (see fuzz/README.md); the checks live in `pgm_fuzz::carmen`.

libfuzzer_sys::fuzz_target!(|data: &[u8]| pgm_fuzz::carmen(data));
