//! The one error type of the identification library.

use std::path::PathBuf;

/// Everything that can go wrong inside `identify`.
///
/// Data problems carry a message that says what to do about them; the command line maps
/// [`Error::is_bad_input`] to exit code 2 and everything else to exit code 1.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A data file could not be parsed or violates the format contract.
    #[error("{file}{at}{col}: {msg}", at = if *.line > 0 { format!(":{}", .line) } else { String::new() }, col = .column.as_ref().map(|c| format!(" column '{c}'")).unwrap_or_default())]
    BadFile {
        /// The offending file.
        file: PathBuf,
        /// 1-based line number (0 when the problem is the whole file).
        line: usize,
        /// Column name, when one column is at fault.
        column: Option<String>,
        /// What is wrong and how to fix it.
        msg: String,
    },
    /// The input is readable but unusable for the requested operation
    /// (e.g. no excitation in band, too few samples, inconsistent channels).
    #[error("{0}")]
    BadInput(String),
    /// A numerical procedure failed (singular system, no convergence).
    #[error("numerical failure: {0}")]
    Numerical(String),
    /// A twin file has a schema this version cannot read.
    #[error("{file}: {msg}")]
    Schema {
        /// The twin file.
        file: PathBuf,
        /// What is wrong (e.g. version too new) and what to do.
        msg: String,
    },
    /// Operating-system I/O failure.
    #[error("{path}: {source}")]
    Io {
        /// The path being read or written.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// JSON (de)serialisation failure of a twin file, with the place in the file.
    #[error("{path}{at}: not a valid twin file: {msg}", at = if *.line > 0 { format!(":{}:{}", .line, .column) } else { String::new() })]
    Json {
        /// The path being read or written.
        path: PathBuf,
        /// 1-based line of the fault (0 when unknown, e.g. when writing).
        line: usize,
        /// 1-based column of the fault (0 when unknown).
        column: usize,
        /// What serde_json found wrong, without its own "at line L column C".
        msg: String,
    },
}

impl Error {
    /// True when the error is the user's input (exit code 2), false for internal failures.
    pub fn is_bad_input(&self) -> bool {
        matches!(
            self,
            Error::BadFile { .. } | Error::BadInput(_) | Error::Schema { .. } | Error::Json { .. }
        ) || matches!(self, Error::Io { source, .. } if matches!(
            source.kind(),
            // a missing file, a folder given for a file, a file that is not text
            std::io::ErrorKind::NotFound
                | std::io::ErrorKind::IsADirectory
                | std::io::ErrorKind::InvalidData
        ))
    }

    /// Shorthand for a [`Error::BadFile`].
    pub fn bad_file(
        file: impl Into<PathBuf>,
        line: usize,
        column: Option<&str>,
        msg: impl Into<String>,
    ) -> Self {
        Error::BadFile {
            file: file.into(),
            line,
            column: column.map(str::to_owned),
            msg: msg.into(),
        }
    }

    /// A serde_json error of the twin file `path`: its line and column moved into the
    /// error's place (`file:line:column`), so the message says them once.
    pub fn json(path: impl Into<PathBuf>, e: &serde_json::Error) -> Self {
        let text = e.to_string();
        let at = format!(" at line {} column {}", e.line(), e.column());
        let msg = text.strip_suffix(&at).unwrap_or(&text).to_string();
        Error::Json {
            path: path.into(),
            line: e.line(),
            column: e.column(),
            msg,
        }
    }

    /// Wraps an I/O error with its path.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }
}

/// Result alias of this crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;
