//! The sorting methods, each a [`Controller`] and an explicit finite state
//! machine: [`Bhd`], [`ProbSeek`] and [`CacheCons`] with its variants.
//! [`Method`] names them and [`build`] makes one.
//!
//! ```
//! use colony_sort::methods::{build, Method};
//! use colony_sort::params::SortParams;
//! let method: Method = "cachecons-informed".parse().unwrap();
//! let robot = build(method, &SortParams::default(), 2, 187.0);
//! assert_eq!(robot.state(), "PU_SCAN");
//! assert_eq!(robot.cache_points().len(), 2);
//! assert!("cachecon".parse::<Method>().unwrap_err().to_string().contains("probseek"));
//! ```

mod bhd;
mod cachecons;
mod caches;
mod common;
mod probseek;

use std::fmt;
use std::str::FromStr;

pub use bhd::{Bhd, BhdState};
pub use cachecons::{informed_caches, CacheCons, CacheConsState, CacheConsVariant};
pub use caches::{CacheMemory, CachePoint, Separation};
pub use probseek::{ProbSeek, ProbSeekState};

use crate::params::SortParams;
use crate::Controller;

/// A sorting method by name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Method {
    /// `bhd`
    Bhd,
    /// `probseek`
    ProbSeek,
    /// `cachecons`
    CacheCons,
    /// `cachecons-informed`
    CacheConsInformed,
    /// `cachecons-ignore`
    CacheConsIgnore,
    /// `cachecons-erase`
    CacheConsErase,
}

impl Method {
    /// Every method, in the order of the names.
    pub const ALL: [Method; 6] = [
        Method::Bhd,
        Method::ProbSeek,
        Method::CacheCons,
        Method::CacheConsInformed,
        Method::CacheConsIgnore,
        Method::CacheConsErase,
    ];

    /// The name `FromStr` reads.
    pub fn name(self) -> &'static str {
        match self {
            Method::Bhd => "bhd",
            Method::ProbSeek => "probseek",
            Method::CacheCons => "cachecons",
            Method::CacheConsInformed => "cachecons-informed",
            Method::CacheConsIgnore => "cachecons-ignore",
            Method::CacheConsErase => "cachecons-erase",
        }
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A method name that is not one of [`Method::ALL`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown method `{name}`; valid methods: bhd, probseek, cachecons, cachecons-informed, cachecons-ignore, cachecons-erase")]
pub struct UnknownMethod {
    /// The name that was not recognised.
    pub name: String,
}

impl FromStr for Method {
    type Err = UnknownMethod;

    /// Reads a name, ignoring case and surrounding space, `_` standing for `-`.
    fn from_str(s: &str) -> Result<Method, UnknownMethod> {
        let wanted = s.trim().to_ascii_lowercase().replace('_', "-");
        Method::ALL
            .into_iter()
            .find(|m| m.name() == wanted)
            .ok_or_else(|| UnknownMethod {
                name: s.to_string(),
            })
    }
}

/// One robot's controller for `method`. `n_types` and `arena_width` (cm)
/// place CACHECONS_INFORMED's caches; `cachecons-erase` uses
/// `params.cache.erase_probability`.
pub fn build(
    method: Method,
    params: &SortParams,
    n_types: usize,
    arena_width: f64,
) -> Box<dyn Controller> {
    match method {
        Method::Bhd => Box::new(Bhd::new(params)),
        Method::ProbSeek => Box::new(ProbSeek::new(params)),
        Method::CacheCons => Box::new(CacheCons::new(params, CacheConsVariant::Standard)),
        Method::CacheConsInformed => Box::new(CacheCons::new(
            params,
            CacheConsVariant::Informed {
                n_types,
                arena_width,
            },
        )),
        Method::CacheConsIgnore => {
            Box::new(CacheCons::new(params, CacheConsVariant::IgnoreSeparation))
        }
        Method::CacheConsErase => Box::new(CacheCons::new(
            params,
            CacheConsVariant::EraseMemory {
                p: params.cache.erase_probability,
            },
        )),
    }
}
