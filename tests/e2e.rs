//! End-to-end tests that run hexbake's binaries.
