//! [`ConfigError`]: what is wrong with a mission, naming the file, the key and why.

/// Something wrong with a mission: the file, the key and why.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The mission file is larger than [`MAX_FILE_BYTES`](super::MAX_FILE_BYTES).
    #[error("{origin}: the mission file is larger than {limit} bytes: not a mission file (the limit keeps a wrong path, e.g. /dev/zero, from being read until memory runs out)")]
    TooLarge {
        /// The file.
        origin: String,
        /// The limit, bytes.
        limit: u64,
    },
    /// The mission file could not be read.
    #[error("{origin}: cannot read the mission file: {source}")]
    Read {
        /// The file.
        origin: String,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The text is not valid TOML.
    #[error("{origin}: line {line}, column {column}: invalid TOML: {message}")]
    Syntax {
        /// The file.
        origin: String,
        /// 1-based line of the error.
        line: usize,
        /// 1-based column of the error.
        column: usize,
        /// toml's description.
        message: String,
    },
    /// A key is unknown, missing or of the wrong type.
    #[error("{origin}: {key}: {message} (line {line}, column {column})")]
    Schema {
        /// The file.
        origin: String,
        /// Dotted path of the key at fault (`field.width`, `faults[0].at`).
        key: String,
        /// 1-based line of the error.
        line: usize,
        /// 1-based column of the error.
        column: usize,
        /// toml's and serde's description.
        message: String,
    },
    /// A value is out of range or inconsistent with another key.
    #[error("{origin}: {key} = {value}: {reason}")]
    Invalid {
        /// The file.
        origin: String,
        /// Dotted path of the key at fault.
        key: String,
        /// The offending value, as written in TOML.
        value: String,
        /// Why it is refused.
        reason: String,
    },
}

impl ConfigError {
    /// The file (or other origin) the error is about.
    pub fn origin(&self) -> &str {
        match self {
            ConfigError::Read { origin, .. }
            | ConfigError::TooLarge { origin, .. }
            | ConfigError::Syntax { origin, .. }
            | ConfigError::Schema { origin, .. }
            | ConfigError::Invalid { origin, .. } => origin,
        }
    }

    /// The dotted key at fault, if the error is about one key.
    pub fn key(&self) -> Option<&str> {
        match self {
            ConfigError::Schema { key, .. } | ConfigError::Invalid { key, .. } => Some(key),
            ConfigError::Read { .. }
            | ConfigError::TooLarge { .. }
            | ConfigError::Syntax { .. } => None,
        }
    }
}
