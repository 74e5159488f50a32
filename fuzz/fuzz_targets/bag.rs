#![no_main]
//! cargo fuzz target `bag` (see fuzz/README.md); the checks live in `pgm_fuzz::bag`.

libfuzzer_sys::fuzz_target!(|data: &[u8]| pgm_fuzz::bag(data));
