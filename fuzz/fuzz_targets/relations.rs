#![no_main]
//! cargo fuzz target `relations` (see fuzz/README.md); the checks live in `pgm_fuzz::relations`.

libfuzzer_sys::fuzz_target!(|data: &[u8]| pgm_fuzz::relations(data));
