//! Holder crate for the end-to-end tests in `e2e.rs`.
