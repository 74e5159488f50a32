//! # pgm-baselines
//!
//! The methods the papers compare against, implemented on the same scan types as the
//! CRF models so comparisons run on identical inputs.
