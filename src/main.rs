//! The `radtrace` command: see `radtrace --help`.
fn main() {
    std::process::exit(radtrace::cli::main());
}
