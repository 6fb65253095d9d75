//! Reading a [`SceneConfig`] from TOML, with errors that say where.

use std::path::Path;

use crate::config::SceneConfig;
use crate::error::{ConfigError, SimError};

impl SceneConfig {
    /// Parses and validates a TOML text. Errors name the line and the field.
    pub fn from_toml_str(text: &str) -> Result<SceneConfig, SimError> {
        parse(text, "<string>")
    }

    /// Reads, parses and validates a TOML file. Errors name the file, the line and the field.
    pub fn from_file(path: impl AsRef<Path>) -> Result<SceneConfig, SimError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|source| SimError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        parse(&text, &path.display().to_string())
    }
}

/// Parses and validates `text`; errors carry `origin` (a file name), the line and
/// the dotted field name.
pub(crate) fn parse(text: &str, origin: &str) -> Result<SceneConfig, SimError> {
    let cfg: SceneConfig = toml::from_str(text).map_err(|e| {
        let (line, column, field) = match e.span() {
            Some(span) => {
                let (line, column) = line_column(text, span.start);
                (Some(line), Some(column), field_at(text, span.start))
            }
            None => (None, None, None),
        };
        SimError::Config(ConfigError {
            origin: origin.to_string(),
            line,
            column,
            field,
            message: e.message().trim().to_string(),
        })
    })?;
    cfg.validate().map_err(|e| match e {
        SimError::Config(mut c) => {
            c.origin = origin.to_string();
            if let Some(field) = &c.field {
                c.line = line_of_field(text, field);
            }
            SimError::Config(c)
        }
        other => other,
    })?;
    Ok(cfg)
}

/// 1-based line and column of a byte offset.
fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, column)
}

/// Walks the lines of a TOML text, yielding (line number, dotted key or table name).
fn keys(text: &str) -> impl Iterator<Item = (usize, String)> + '_ {
    let mut table = String::new();
    text.lines().enumerate().filter_map(move |(i, raw)| {
        let l = raw.trim();
        if l.starts_with('[') {
            let name = l
                .trim_start_matches('[')
                .split(']')
                .next()
                .unwrap_or("")
                .trim();
            table = name.replace(['"', ' '], "");
            return Some((i + 1, table.clone()));
        }
        if l.is_empty() || l.starts_with('#') {
            return None;
        }
        let key = l.split('=').next()?.trim().replace(['"', ' '], "");
        if table.is_empty() {
            Some((i + 1, key))
        } else {
            Some((i + 1, format!("{table}.{key}")))
        }
    })
}

/// The dotted key (or table) defined on the line holding `offset`.
fn field_at(text: &str, offset: usize) -> Option<String> {
    let (line, _) = line_column(text, offset);
    keys(text).find(|(l, _)| *l == line).map(|(_, k)| k)
}

/// The line defining a dotted key, if the text defines it.
fn line_of_field(text: &str, field: &str) -> Option<usize> {
    keys(text).find(|(_, k)| k == field).map(|(l, _)| l)
}
