//! Errors that reach the user: one line each, naming the file and place.

use std::fmt;
use std::path::{Path, PathBuf};

/// Where in an input file a problem is: line and column, both 1-based.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Pos {
    /// 1-based line.
    pub line: u32,
    /// 1-based column (0 when only the line is known).
    pub col: u32,
}

impl fmt::Display for Pos {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.col > 0 {
            write!(f, "{}:{}", self.line, self.col)
        } else {
            write!(f, "{}", self.line)
        }
    }
}

/// Every error radtrace reports. `Display` gives the one line the user sees.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A problem in an input file (scene, mesh, patch file, solution file, image).
    #[error("{}{}: {msg}", path.display(), pos.map(|p| format!(":{p}")).unwrap_or_default())]
    Input {
        /// The file.
        path: PathBuf,
        /// Where in the file, when known.
        pos: Option<Pos>,
        /// What is wrong.
        msg: String,
    },
    /// A file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// An output (image, statistics, solution) could not be written.
    #[error("cannot write {}: {source}", path.display())]
    Output {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// A bad command-line value or a request that cannot be carried out.
    #[error("{0}")]
    Usage(String),
}

impl Error {
    /// An error in `path` at an optional position.
    pub fn input(path: &Path, pos: Option<Pos>, msg: impl Into<String>) -> Self {
        Error::Input {
            path: path.to_path_buf(),
            pos,
            msg: msg.into(),
        }
    }

    /// An I/O error on `path`.
    pub fn io(path: &Path, source: std::io::Error) -> Self {
        Error::Io {
            path: path.to_path_buf(),
            source,
        }
    }

    /// An output `path` that could not be written.
    pub fn output(path: &Path, source: std::io::Error) -> Self {
        Error::Output {
            path: path.to_path_buf(),
            source,
        }
    }

    /// The process exit code for this error: 2 for bad input or usage (an input file
    /// that cannot be read included), 1 when an output cannot be written.
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::Output { .. } => 1,
            Error::Input { .. } | Error::Io { .. } | Error::Usage(_) => 2,
        }
    }
}

/// radtrace's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// `Ok` if `v`, the value of the command line's flag `--name`, is at least 1; else
/// the usage error "--name V: must be at least 1" (for settings' `validate`).
pub fn at_least_one(name: &str, v: u32) -> Result<()> {
    if v >= 1 {
        Ok(())
    } else {
        Err(Error::Usage(format!("--{name} {v}: must be at least 1")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exit_codes_tell_bad_input_from_failed_output() {
        let e = std::io::Error::new(std::io::ErrorKind::NotFound, "gone");
        assert_eq!(Error::io(Path::new("a.xml"), e).exit_code(), 2);
        assert_eq!(Error::input(Path::new("a.xml"), None, "bad").exit_code(), 2);
        assert_eq!(Error::Usage("bad flag".into()).exit_code(), 2);
        let e = std::io::Error::new(std::io::ErrorKind::PermissionDenied, "read-only");
        let out = Error::output(Path::new("out.png"), e);
        assert_eq!(out.exit_code(), 1);
        assert_eq!(out.to_string(), "cannot write out.png: read-only");
    }
}
