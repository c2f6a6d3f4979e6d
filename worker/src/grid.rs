//! Hexagonal view-cell grid (DESIGN.md "Hex grid"; paper 000 §3.1.1).
//!
//! TODO(issue 2 item 6).
