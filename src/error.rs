//! One error type for the library, sorted by who can fix the problem: the user
//! (bad input or usage, exit code 2) or the run itself (exit code 1).

use std::path::{Path, PathBuf};

pub type Result<T, E = Error> = std::result::Result<T, E>;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file the user gave is missing, unreadable or not what it should be.
    #[error("{}: {message}", path.display())]
    Input { path: PathBuf, message: String },
    /// Parameters or command-line arguments that cannot work together.
    #[error("{0}")]
    Usage(String),
    /// The run failed for a reason that is not the input's fault (disk full, ...).
    #[error("{context}: {source}")]
    Io {
        context: String,
        #[source]
        source: std::io::Error,
    },
    /// A computation could not produce a result (e.g. no path between two cells).
    #[error("{0}")]
    Failed(String),
    /// Not an error of the run: a check found something out of date (exit code 1).
    #[error("{0}")]
    Stale(String),
}

impl Error {
    pub fn input(path: impl AsRef<Path>, message: impl Into<String>) -> Self {
        Error::Input {
            path: path.as_ref().to_path_buf(),
            message: message.into(),
        }
    }

    pub fn io(context: impl Into<String>, source: std::io::Error) -> Self {
        Error::Io {
            context: context.into(),
            source,
        }
    }

    /// A write to a pipe whose reader has gone (`imitate cat ... | head`): the reader
    /// took what it wanted, so the command line ends quietly with success.
    pub fn is_broken_pipe(&self) -> bool {
        matches!(self, Error::Io { source, .. } if source.kind() == std::io::ErrorKind::BrokenPipe)
    }

    /// Exit code of the command line: 2 for what the user must fix, 1 otherwise.
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::Input { .. } | Error::Usage(_) => 2,
            Error::Io { .. } | Error::Failed(_) | Error::Stale(_) => 1,
        }
    }
}

/// Reads a whole file, turning "not found" and friends into an input error naming the file.
pub fn read_input(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).map_err(|e| Error::input(path, describe_io(&e)))
}

/// Opens a file for reading with an input error naming the file on failure.
pub fn open_input(path: &Path) -> Result<std::fs::File> {
    std::fs::File::open(path).map_err(|e| Error::input(path, describe_io(&e)))
}

fn describe_io(e: &std::io::Error) -> String {
    match e.kind() {
        std::io::ErrorKind::NotFound => "no such file or directory".to_string(),
        std::io::ErrorKind::PermissionDenied => "permission denied".to_string(),
        _ => e.to_string(),
    }
}

/// The values of parallel results, or the error of the first failure in input order,
/// so that which error is reported does not depend on thread timing (rayon's own
/// `collect::<Result<..>>` returns whichever failure it meets first).
pub fn first_error_in_order<T, E>(
    results: Vec<std::result::Result<T, E>>,
) -> std::result::Result<Vec<T>, E> {
    results.into_iter().collect()
}

std::thread_local! {
    /// How deep this thread is inside [`guard_decoder`].
    static GUARDED: std::cell::Cell<u32> = const { std::cell::Cell::new(0) };
}

/// Runs third-party decoding that may panic on damaged input (the `parquet` and `mcap`
/// crates assert or index out of bounds on some corrupt records), turning such a panic
/// into an error message, so that a damaged file is an input error (exit code 2) and
/// never a crash. Our own code checks its input instead; this is only for what we
/// cannot check before calling in.
pub fn catch_decoder_panic<T>(work: impl FnOnce() -> T) -> std::result::Result<T, String> {
    GUARDED.with(|g| g.set(g.get() + 1));
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(work));
    GUARDED.with(|g| g.set(g.get() - 1));
    result.map_err(|payload| {
        payload
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_else(|| "the decoder failed".into())
    })
}

/// [`catch_decoder_panic`] for work on one file: a panic is an input error naming it.
pub fn guard_decoder<T>(path: &Path, what: &str, work: impl FnOnce() -> Result<T>) -> Result<T> {
    catch_decoder_panic(work).unwrap_or_else(|cause| {
        Err(Error::input(
            path,
            format!("{what}: the file is damaged ({cause})"),
        ))
    })
}

/// Installs a panic hook that is silent for the panics [`guard_decoder`] turns into
/// errors (and [`catch_decoder_panic`] to messages) and hands every other panic (a
/// bug) to the hook installed before.
pub fn install_panic_hook() {
    let previous = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        if GUARDED.with(|g| g.get()) == 0 {
            previous(info);
        }
    }));
}
