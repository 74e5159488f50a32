#![no_main]
//! cargo fuzz target `ros_message` (see fuzz/README.md); the checks live in `pgm_fuzz::ros_message`.

libfuzzer_sys::fuzz_target!(|data: &[u8]| pgm_fuzz::ros_message(data));
