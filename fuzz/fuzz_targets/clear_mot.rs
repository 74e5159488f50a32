#![no_main]
//! cargo fuzz target `clear_mot` (see fuzz/README.md); the checks live in `pgm_fuzz::clear_mot`.

libfuzzer_sys::fuzz_target!(|data: &[u8]| pgm_fuzz::clear_mot(data));
