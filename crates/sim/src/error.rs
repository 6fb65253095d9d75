//! The one error type of this crate.

use std::fmt;
use std::path::PathBuf;

/// Everything that can go wrong when building or loading a world.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// A scene configuration could not be parsed or holds an impossible value.
    #[error("{0}")]
    Config(ConfigError),
    /// A configuration file could not be read.
    #[error("cannot read scene configuration {path}", path = .path.display())]
    Io {
        /// The file that could not be read.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// Robots or pucks could not be placed (arena too crowded, or a chosen
    /// position outside the arena).
    #[error("layout: {0}")]
    Layout(String),
    /// A tile map with impossible dimensions or contents.
    #[error("tile map: {0}")]
    Map(String),
    /// A robot or box could not be put where asked on a [`crate::field::Field`];
    /// `reason` says what is in the way, so a caller can try elsewhere.
    #[error("cannot place {what} at ({x}, {y}): {reason}")]
    Placement {
        /// What was being placed, e.g. `robot 3` or `box 0`.
        what: String,
        /// The asked position, world frame, cm.
        x: f64,
        /// The asked position, world frame, cm.
        y: f64,
        /// What is in the way.
        reason: crate::types::Refusal,
    },
    /// An id that names no robot or box of a [`crate::field::Field`].
    #[error("no {what} with id {id}")]
    UnknownId {
        /// `robot` or `box`.
        what: &'static str,
        /// The id asked for.
        id: usize,
    },
}

/// A bad scene configuration: where it is and what is wrong.
///
/// Displayed as `origin:line: field `name`: message`, for example
/// `configs/scene.toml:7: field `robots.count`: must be at least 1`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ConfigError {
    /// The file name, or `<string>` for text given directly.
    pub origin: String,
    /// 1-based line of the offending text, when it is known.
    pub line: Option<usize>,
    /// 1-based column of the offending text, when it is known.
    pub column: Option<usize>,
    /// The dotted field name (`pucks.kinds`), when it is known.
    pub field: Option<String>,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.origin)?;
        if let Some(line) = self.line {
            write!(f, ":{line}")?;
            if let Some(column) = self.column {
                write!(f, ":{column}")?;
            }
        }
        write!(f, ": ")?;
        if let Some(field) = &self.field {
            write!(f, "field `{field}`: ")?;
        }
        write!(f, "{}", self.message)
    }
}

impl SimError {
    /// A configuration error about one field, not yet tied to a source text.
    pub(crate) fn invalid(field: &str, message: impl Into<String>) -> SimError {
        SimError::Config(ConfigError {
            origin: "<config>".to_string(),
            line: None,
            column: None,
            field: Some(field.to_string()),
            message: message.into(),
        })
    }
}
