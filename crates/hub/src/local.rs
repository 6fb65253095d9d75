//! A hub for a program that needs one: the one given, or one started on a
//! thread of this process. [`HubSite`] makes that choice once; programs whose
//! hub may log MCAP (`colony demo`, `colony game`) open the hub as `colony hub`
//! does and serve it with [`HubThread`].
//!
//! ```no_run
//! use std::sync::{atomic::AtomicBool, Arc};
//! use colony_hub::{HubSite, HubSpec};
//! let stop = Arc::new(AtomicBool::new(false));
//! // No hub given: start one on loopback, on a port the system picks.
//! let site = HubSite::here_or_elsewhere(None, &HubSpec::new("127.0.0.1:0"), &stop)?;
//! println!("hub on {}", site.addr());
//! // ... connect clients to site.addr() ...
//! site.stop()?; // sets `stop`, then waits for the hub's thread
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::io;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;

use crate::log::{LogError, LogWriter, Rotation};
use crate::{HubConfig, Server};

/// How to start a hub: where it listens, its limits, and its traffic log.
#[derive(Debug, Clone)]
pub struct HubSpec {
    /// The address to listen on (`127.0.0.1:0`: loopback, any free port).
    pub bind: String,
    /// Its limits.
    pub config: HubConfig,
    /// Append every accepted packet to this traffic log.
    pub log: Option<PathBuf>,
    /// Rotate that log by size (`None`: it grows without bound).
    pub log_rotation: Option<Rotation>,
}

impl HubSpec {
    /// A hub on `bind` with the default limits and no log.
    pub fn new(bind: impl Into<String>) -> HubSpec {
        HubSpec {
            bind: bind.into(),
            config: HubConfig::default(),
            log: None,
            log_rotation: None,
        }
    }
}

/// Why a hub could not start.
#[derive(Debug, thiserror::Error)]
pub enum StartError {
    /// The address cannot be listened on (in use, not ours, not an address).
    #[error("cannot listen on `{addr}`")]
    Bind {
        /// The address asked for.
        addr: String,
        /// What the system said.
        source: io::Error,
    },
    /// The traffic log cannot be opened.
    #[error(transparent)]
    Log(#[from] LogError),
    /// The hub's thread could not be started.
    #[error("cannot start the hub's thread")]
    Thread(#[source] io::Error),
}

/// Why a hub's thread ended badly.
#[derive(Debug, thiserror::Error)]
pub enum HubThreadError {
    /// Its socket or its log failed.
    #[error("the hub failed")]
    Failed(#[source] io::Error),
    /// It panicked.
    #[error("the hub thread panicked")]
    Panicked,
}

impl Server {
    /// Binds a hub as `spec` says and opens its log. A torn record at the end
    /// of the log (a write a crash cut short) is cut off, with a warning; a log
    /// corrupt anywhere else is refused ([`LogError::WontCut`]), untouched.
    pub fn start(spec: &HubSpec) -> Result<Server, StartError> {
        let mut server =
            Server::bind(spec.bind.as_str(), spec.config.clone()).map_err(|source| {
                StartError::Bind {
                    addr: spec.bind.clone(),
                    source,
                }
            })?;
        if let Some(path) = &spec.log {
            let mut log = LogWriter::open_warning(path)?;
            if let Some(r) = spec.log_rotation {
                log = log.with_rotation(r);
            }
            server = server.with_log(log);
        }
        Ok(server)
    }
}

/// A hub serving on a thread of this process until its stop flag is set.
pub struct HubThread {
    addr: std::net::SocketAddr,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<io::Result<()>>>,
}

impl HubThread {
    /// Serves `server` on a new thread until `stop` is set.
    pub fn spawn(mut server: Server, stop: &Arc<AtomicBool>) -> Result<HubThread, StartError> {
        let addr = server.local_addr().map_err(StartError::Thread)?;
        let s = stop.clone();
        let thread = std::thread::Builder::new()
            .name("hub".into())
            .spawn(move || server.run(&s))
            .map_err(StartError::Thread)?;
        Ok(HubThread {
            addr,
            stop: stop.clone(),
            thread: Some(thread),
        })
    }

    /// Where it listens.
    pub fn addr(&self) -> std::net::SocketAddr {
        self.addr
    }

    /// Sets the stop flag (which others may share) and waits for the hub to
    /// flush its log and end.
    pub fn stop(mut self) -> Result<(), HubThreadError> {
        self.join()
    }

    fn join(&mut self) -> Result<(), HubThreadError> {
        self.stop.store(true, Ordering::Relaxed);
        match self.thread.take().map(JoinHandle::join) {
            None | Some(Ok(Ok(()))) => Ok(()),
            Some(Ok(Err(e))) => Err(HubThreadError::Failed(e)),
            Some(Err(_)) => Err(HubThreadError::Panicked),
        }
    }
}

impl Drop for HubThread {
    /// A hub left running would keep the process alive: stop it however we leave.
    fn drop(&mut self) {
        let _ = self.join();
    }
}

/// Where a program's hub is: one running elsewhere that it was told of, or
/// one it started here.
pub enum HubSite {
    /// A hub at this address, which someone else runs.
    Elsewhere(String),
    /// A hub on a thread of this process.
    Here(HubThread),
}

impl HubSite {
    /// The hub at `elsewhere` if one is given; otherwise one started as
    /// `spec` says, on a thread of this process, serving until `stop` is set.
    pub fn here_or_elsewhere(
        elsewhere: Option<&str>,
        spec: &HubSpec,
        stop: &Arc<AtomicBool>,
    ) -> Result<HubSite, StartError> {
        Ok(match elsewhere {
            Some(addr) => HubSite::Elsewhere(addr.to_string()),
            None => HubSite::Here(HubThread::spawn(Server::start(spec)?, stop)?),
        })
    }

    /// The hub's address, for clients.
    pub fn addr(&self) -> String {
        match self {
            HubSite::Elsewhere(a) => a.clone(),
            HubSite::Here(h) => h.addr().to_string(),
        }
    }

    /// Stops a hub started here (see [`HubThread::stop`]); one elsewhere is left alone.
    pub fn stop(self) -> Result<(), HubThreadError> {
        match self {
            HubSite::Elsewhere(_) => Ok(()),
            HubSite::Here(h) => h.stop(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_given_hub_is_used_and_none_is_started() {
        let stop = Arc::new(AtomicBool::new(false));
        let site =
            HubSite::here_or_elsewhere(Some("10.0.0.1:7400"), &HubSpec::new("x"), &stop).unwrap();
        assert_eq!(site.addr(), "10.0.0.1:7400");
        site.stop().unwrap();
        assert!(!stop.load(Ordering::Relaxed));
    }

    #[test]
    fn without_one_a_hub_serves_here_until_stopped() {
        let stop = Arc::new(AtomicBool::new(false));
        let site = HubSite::here_or_elsewhere(None, &HubSpec::new("127.0.0.1:0"), &stop).unwrap();
        let addr: std::net::SocketAddr = site.addr().parse().unwrap();
        assert_ne!(addr.port(), 0);
        site.stop().unwrap();
        assert!(stop.load(Ordering::Relaxed));
    }

    #[test]
    fn a_taken_address_is_named() {
        let taken = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
        let spec = HubSpec::new(taken.local_addr().unwrap().to_string());
        let stop = Arc::new(AtomicBool::new(false));
        match HubSite::here_or_elsewhere(None, &spec, &stop) {
            Err(StartError::Bind { addr, .. }) => assert_eq!(addr, spec.bind),
            _ => panic!("the address is taken"),
        }
    }
}
