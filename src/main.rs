use clap::Parser;

/// mimalloc keeps freed megabyte buffers (chunks, grids, feature planes) for reuse
/// instead of handing them back to the kernel and faulting them in again, which on
/// several threads serialises on the kernel's page-table lock.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() {
    imitate::error::install_panic_hook();
    let cli = imitate::cli::Cli::parse();
    let level = match cli.verbose {
        0 => "warn",
        1 => "info",
        _ => "debug",
    };
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(level));
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .init();
    if let Err(e) = imitate::cli::run(cli) {
        if e.is_broken_pipe() {
            return;
        }
        eprintln!("error: {e}");
        std::process::exit(e.exit_code());
    }
}
