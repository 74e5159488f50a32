#![no_main]
//! cargo fuzz target `leigh` (see fuzz/README.md); the checks live in `pgm_fuzz::leigh`.

libfuzzer_sys::fuzz_target!(|data: &[u8]| pgm_fuzz::leigh(data));
