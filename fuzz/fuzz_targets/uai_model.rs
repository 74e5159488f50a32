#![no_main]
//! cargo fuzz target `uai_model` (see fuzz/README.md); the checks live in `pgm_fuzz::uai_model`.

libfuzzer_sys::fuzz_target!(|data: &[u8]| pgm_fuzz::uai_model(data));
