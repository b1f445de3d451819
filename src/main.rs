//! The `radtrace` command.
fn main() {}
