//! What a bridge is told: its hub, its site, its Zenoh side and its rules,
//! from a TOML file, with the command line's flags on top.
//!
//! ```toml
//! hub = "127.0.0.1:7400"
//! site = "lab"
//! mode = "peer"                      # or "client" (through a Zenoh router)
//! connect = ["tcp/10.0.0.2:7447"]
//! listen = ["tcp/0.0.0.0:7447"]
//! export = ["*"]                     # channels other sites may have from this hub
//! import = ["vision", "game.*"]      # channels this hub's clients may have from other sites
//! ```

use std::path::Path;
use std::time::Duration;

use serde::Deserialize;

use crate::keys::{Site, SiteError};

/// How the bridge joins Zenoh.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    /// Talks to other peers directly (and through routers, if given).
    #[default]
    Peer,
    /// Talks only through the Zenoh router it connects to.
    Client,
}

impl std::str::FromStr for Mode {
    type Err = String;
    fn from_str(s: &str) -> Result<Mode, String> {
        match s {
            "peer" => Ok(Mode::Peer),
            "client" => Ok(Mode::Client),
            other => Err(format!(
                "unknown Zenoh mode `{other}` (expected peer or client)"
            )),
        }
    }
}

impl Mode {
    /// The word Zenoh's configuration uses.
    pub fn as_str(self) -> &'static str {
        match self {
            Mode::Peer => "peer",
            Mode::Client => "client",
        }
    }
}

/// A channel pattern: a name in which `*` stands for any run of characters.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Pattern(String);

impl Pattern {
    /// A pattern from its text.
    pub fn new(text: &str) -> Pattern {
        Pattern(text.to_owned())
    }

    /// Whether `name` matches.
    pub fn matches(&self, name: &str) -> bool {
        let mut parts = self.0.split('*');
        let first = parts.next().unwrap_or_default();
        let Some(mut rest) = name.strip_prefix(first) else {
            return false;
        };
        let parts: Vec<&str> = parts.collect();
        let Some((last, middle)) = parts.split_last() else {
            return rest.is_empty();
        };
        for p in middle {
            match rest.find(p) {
                Some(i) => rest = &rest[i + p.len()..],
                None => return false,
            }
        }
        rest.len() >= last.len() && rest.ends_with(last)
    }
}

/// Whether any of `patterns` matches `name`.
pub fn any_matches(patterns: &[Pattern], name: &str) -> bool {
    patterns.iter().any(|p| p.matches(name))
}

/// The bridge's whole configuration.
#[derive(Debug, Clone)]
pub struct BridgeConfig {
    /// The local hub.
    pub hub: String,
    /// This site's name, unique among the sites bridged together.
    pub site: Site,
    /// How to join Zenoh.
    pub mode: Mode,
    /// Zenoh endpoints to connect to (`tcp/HOST:PORT`).
    pub connect: Vec<String>,
    /// Zenoh endpoints to listen on.
    pub listen: Vec<String>,
    /// Channels other sites may take from this hub.
    pub export: Vec<Pattern>,
    /// Channels this hub's clients may take from other sites.
    pub import: Vec<Pattern>,
    /// How often the hub is asked who subscribes to what.
    pub poll: Duration,
}

impl BridgeConfig {
    /// A bridge for `site` to the hub at `hub`, exporting and importing
    /// everything, as a Zenoh peer with no endpoints yet.
    pub fn new(hub: &str, site: Site) -> BridgeConfig {
        BridgeConfig {
            hub: hub.to_owned(),
            site,
            mode: Mode::Peer,
            connect: Vec::new(),
            listen: Vec::new(),
            export: vec![Pattern::new("*")],
            import: vec![Pattern::new("*")],
            poll: Duration::from_millis(250),
        }
    }

    /// Reads a TOML file; every field is optional but `site`.
    pub fn from_file(path: &Path) -> Result<BridgeConfig, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Read {
            path: path.display().to_string(),
            source,
        })?;
        BridgeConfig::from_toml(&text).map_err(|e| match e {
            ConfigError::Toml(msg) => ConfigError::Toml(format!("{}: {msg}", path.display())),
            other => other,
        })
    }

    /// Reads TOML text.
    pub fn from_toml(text: &str) -> Result<BridgeConfig, ConfigError> {
        let file: File = toml::from_str(text).map_err(|e| ConfigError::Toml(e.to_string()))?;
        let site = Site::new(&file.site)?;
        let mut c = BridgeConfig::new(file.hub.as_deref().unwrap_or("127.0.0.1:7400"), site);
        c.mode = file.mode.unwrap_or_default();
        c.connect = file.connect;
        c.listen = file.listen;
        if let Some(e) = file.export {
            c.export = e.iter().map(|p| Pattern::new(p)).collect();
        }
        if let Some(i) = file.import {
            c.import = i.iter().map(|p| Pattern::new(p)).collect();
        }
        if let Some(ms) = file.poll_ms {
            c.poll = Duration::from_millis(ms.clamp(20, 60_000));
        }
        Ok(c)
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    hub: Option<String>,
    site: String,
    mode: Option<Mode>,
    #[serde(default)]
    connect: Vec<String>,
    #[serde(default)]
    listen: Vec<String>,
    export: Option<Vec<String>>,
    import: Option<Vec<String>>,
    poll_ms: Option<u64>,
}

/// A configuration that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read.
    #[error("cannot read the bridge configuration {path}")]
    Read {
        /// The file.
        path: String,
        /// Why.
        source: std::io::Error,
    },
    /// The TOML is not a bridge's.
    #[error("bad bridge configuration: {0}")]
    Toml(String),
    /// The site name cannot be one.
    #[error(transparent)]
    Site(#[from] SiteError),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn patterns_match_whole_names_with_stars_for_any_run() {
        let p = Pattern::new;
        assert!(p("*").matches("vision") && p("*").matches(""));
        assert!(p("vision").matches("vision") && !p("vision").matches("vision2"));
        assert!(p("game.*").matches("game.robot.1") && !p("game.*").matches("game"));
        assert!(p("*.debug").matches("sort.debug") && !p("*.debug").matches("debug"));
        assert!(p("a*b*c").matches("abc") && p("a*b*c").matches("axxbyyc"));
        assert!(!p("a*b*c").matches("acb") && !p("ab*ab").matches("ab"));
    }

    #[test]
    fn a_missing_file_is_named_once_with_its_cause_behind() {
        let e = BridgeConfig::from_file(Path::new("/no/such/bridge.toml")).unwrap_err();
        assert_eq!(
            e.to_string(),
            "cannot read the bridge configuration /no/such/bridge.toml"
        );
        assert!(std::error::Error::source(&e).is_some());
    }

    #[test]
    fn a_file_sets_what_it_names_and_refuses_what_it_does_not_know() {
        let c = BridgeConfig::from_toml(
            "site = \"lab\"\nmode = \"client\"\nconnect = [\"tcp/127.0.0.1:7447\"]\nimport = [\"vision\"]\n",
        )
        .unwrap();
        assert_eq!(c.site.as_str(), "lab");
        assert_eq!(c.mode, Mode::Client);
        assert_eq!(c.connect, ["tcp/127.0.0.1:7447"]);
        assert!(any_matches(&c.import, "vision") && !any_matches(&c.import, "radio"));
        assert!(any_matches(&c.export, "radio"));
        for bad in [
            "",
            "site = \"l b\"",
            "site = \"lab\"\nmodee = \"peer\"",
            "site = \"lab\"\nmode = \"router\"",
        ] {
            assert!(BridgeConfig::from_toml(bad).is_err(), "{bad}");
        }
    }
}
