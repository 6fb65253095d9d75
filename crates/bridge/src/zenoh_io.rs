//! Zenoh's side of the bridge: its callbacks handed to the bridge's thread, a put made as the
//! [`Relay`](crate::relay::Relay) numbered it, and the session's configuration.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{SyncSender, TrySendError};
use std::sync::Arc;

use mio::Waker;
use zenoh::{Session, Wait};

use crate::config::BridgeConfig;
use crate::relay::{Put, Sample, Want};
use crate::stats::{BridgeError, Stats};
use crate::track::Stamp;

/// The longest key a sample may have to be looked at.
const MAX_KEY: usize = 4_096;

/// Passes Zenoh's callbacks to the bridge's thread and wakes it.
#[derive(Clone)]
pub(crate) struct Inbox {
    pub(crate) data: SyncSender<Sample>,
    pub(crate) wants: SyncSender<Want>,
    pub(crate) wants_lost: Arc<AtomicBool>,
    pub(crate) waker: Arc<Waker>,
    pub(crate) stats: Arc<Stats>,
    /// `colony/<this site>/`: this session's own puts, which Zenoh hands its
    /// own subscribers too.
    pub(crate) own_prefix: String,
}

impl Inbox {
    pub(crate) fn data(&self, sample: &zenoh::sample::Sample) {
        let key = sample.key_expr().as_str();
        if key.starts_with(&self.own_prefix) {
            return;
        }
        // Checked before anything is copied: Zenoh delivers samples of any size.
        if key.len() > MAX_KEY || sample.payload().len() > colony_wire::MAX_PACKET {
            Stats::add(&self.stats.rejected, 1);
            return;
        }
        let data = Sample {
            key: key.to_owned(),
            payload: sample.payload().to_bytes().into_owned(),
            priority: sample.priority() as u8,
            stamp: sample
                .attachment()
                .and_then(|a| Stamp::from_bytes(&a.to_bytes())),
        };
        match self.data.try_send(data) {
            Ok(()) => {
                let _ = self.waker.wake();
            }
            Err(TrySendError::Full(_)) => Stats::add(&self.stats.overflow, 1),
            Err(TrySendError::Disconnected(_)) => {}
        }
    }

    pub(crate) fn want(&self, want: Want) {
        match self.wants.try_send(want) {
            Ok(()) => {}
            Err(TrySendError::Full(_)) => self.wants_lost.store(true, Ordering::Relaxed),
            Err(TrySendError::Disconnected(_)) => return,
        }
        let _ = self.waker.wake();
    }
}

/// Puts one packet from the hub, as the relay numbered it.
pub(crate) fn put(session: &Session, put: Put) -> Result<(), String> {
    session
        .put(put.key, put.payload)
        .priority(put.priority)
        .congestion_control(put.congestion)
        .express(put.express)
        .attachment(put.stamp.to_bytes().to_vec())
        .wait()
        .map_err(|e| e.to_string())
}

/// Zenoh's configuration for this bridge: no multicast scouting (explicit
/// endpoints only), and connections retried every 250 ms to 1 s, forever, so
/// a restarted router or peer is found again within a second or two.
pub(crate) fn zenoh_config(c: &BridgeConfig) -> Result<zenoh::Config, BridgeError> {
    let mut z = zenoh::Config::default();
    let json = |v: &[String]| {
        let quoted: Vec<String> = v.iter().map(|e| format!("{e:?}")).collect();
        format!("[{}]", quoted.join(","))
    };
    let set = |z: &mut zenoh::Config, key: &str, value: &str| {
        z.insert_json5(key, value)
            .map_err(|e| BridgeError::Zenoh(format!("{key} = {value}: {e}")))
    };
    set(&mut z, "mode", &format!("{:?}", c.mode.as_str()))?;
    set(&mut z, "connect/endpoints", &json(&c.connect))?;
    set(&mut z, "listen/endpoints", &json(&c.listen))?;
    set(&mut z, "scouting/multicast/enabled", "false")?;
    // A colony packet fits a datagram; Zenoh would otherwise reassemble
    // messages of up to 1 GiB from anyone on the link.
    set(&mut z, "transport/link/rx/max_message_size", "1048576")?;
    // A zero timeout would mean one try and no retry.
    set(&mut z, "connect/timeout_ms", "-1")?;
    set(&mut z, "connect/exit_on_failure", "false")?;
    set(
        &mut z,
        "connect/retry",
        "{period_init_ms: 250, period_max_ms: 1000, period_increase_factor: 2}",
    )?;
    Ok(z)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::keys::Site;

    #[test]
    fn a_bad_endpoint_is_a_clear_error() {
        let mut c = BridgeConfig::new("127.0.0.1:7400", Site::new("lab").unwrap());
        c.connect = vec!["nonsense".into()];
        let Err(e) = zenoh_config(&c) else {
            panic!("a bad endpoint was taken")
        };
        assert!(e.to_string().contains("connect/endpoints"), "{e}");
    }
}
