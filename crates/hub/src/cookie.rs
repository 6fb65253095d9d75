//! Return routability: cookies that prove a source receives at its address.
//!
//! A UDP source address is whatever the sender wrote. Before the hub leases a
//! stream to an address it sends that address a cookie, a keyed hash of it,
//! and leases only when the cookie comes back (QUIC's Retry, DTLS's
//! HelloVerify): a sender that forged the address never sees the cookie. The
//! hub keeps no state for the sources it has not verified, so forged sources
//! cannot fill its memory.

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use colony_wire::Cookie;
use hmac::{Hmac, Mac};
use sha2::Sha256;

/// How long a cookie stays good: a client whose lease lapsed while it kept
/// its cookie comes back without a second round trip within this time.
const EPOCH: Duration = Duration::from_secs(60);

/// The hub's secret and the clock of its epochs.
pub(crate) struct CookieJar {
    secret: [u8; 32],
    started: Instant,
}

impl std::fmt::Debug for CookieJar {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("CookieJar(..)")
    }
}

impl CookieJar {
    /// A jar with a fresh random secret: a restarted hub issues new cookies.
    pub(crate) fn new(now: Instant) -> CookieJar {
        CookieJar {
            secret: rand::random(),
            started: now,
        }
    }

    fn epoch(&self, now: Instant) -> u64 {
        (now.saturating_duration_since(self.started).as_secs() / EPOCH.as_secs()) + 1
    }

    fn for_epoch(&self, src: &SocketAddr, epoch: u64) -> Cookie {
        let mut mac = <Hmac<Sha256> as Mac>::new_from_slice(&self.secret)
            .expect("HMAC takes a key of any length");
        mac.update(&epoch.to_be_bytes());
        match src.ip() {
            std::net::IpAddr::V4(ip) => mac.update(&ip.octets()),
            std::net::IpAddr::V6(ip) => mac.update(&ip.octets()),
        }
        mac.update(&src.port().to_be_bytes());
        let bytes = mac.finalize().into_bytes();
        let mut first = [0; 8];
        first.copy_from_slice(&bytes[..8]);
        // Zero means "no cookie yet" on the wire; a real one never is.
        Cookie(u64::from_be_bytes(first).max(1))
    }

    /// The cookie for `src` now.
    pub(crate) fn issue(&self, src: &SocketAddr, now: Instant) -> Cookie {
        self.for_epoch(src, self.epoch(now))
    }

    /// Whether `cookie` is one this jar gave `src` in this epoch or the last.
    pub(crate) fn check(&self, src: &SocketAddr, now: Instant, cookie: Cookie) -> bool {
        if cookie == Cookie::NONE {
            return false;
        }
        let epoch = self.epoch(now);
        cookie == self.for_epoch(src, epoch) || cookie == self.for_epoch(src, epoch - 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cookie_is_good_for_its_address_only_and_for_two_epochs() {
        let t0 = Instant::now();
        let jar = CookieJar::new(t0);
        let a: SocketAddr = "127.0.0.1:5000".parse().unwrap();
        let b: SocketAddr = "127.0.0.1:5001".parse().unwrap();
        let c = jar.issue(&a, t0);
        assert!(jar.check(&a, t0, c));
        assert!(!jar.check(&b, t0, c));
        assert!(!jar.check(&a, t0, Cookie::NONE));
        assert!(jar.check(&a, t0 + EPOCH + Duration::from_secs(1), c));
        assert!(!jar.check(&a, t0 + EPOCH * 2 + Duration::from_secs(1), c));
        let restarted = CookieJar::new(t0);
        assert!(!restarted.check(&a, t0, c), "a new secret, new cookies");
    }
}
