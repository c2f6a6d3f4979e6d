//! The `worker` binary's subcommands, one module each: its flags (`Args`) and
//! what it does (`run`).

pub mod capture;
pub mod check;
pub mod job;
pub mod view;
