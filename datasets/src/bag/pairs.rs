//! Bag pairs.
