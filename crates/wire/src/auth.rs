//! Packets proven to come from a holder of a shared key.
//!
//! An authenticated packet ends with one more line:
//!
//! ```text
//! @ <hub> 0
//! min_priority value 5
//! auth n 1764000000000000 mac 3f0c…(64 hex digits)
//! ```
//!
//! `mac` is HMAC-SHA256 under the key of every byte before its value (so the
//! header, the body and `auth n N mac ` itself). `n` is the sender's counter:
//! microseconds since the UNIX epoch, and strictly increasing per sender, so a
//! receiver can refuse a packet it has seen (see [`ReplayWindow`]) or one too
//! far from its own clock. Without the line a packet is as before: hand-made
//! packets stay possible wherever a hub does not ask for a key.

use std::fmt::Write as _;
use std::time::{SystemTime, UNIX_EPOCH};

use hmac::{Hmac, Mac};
use sha2::Sha256;

/// The label of the authentication line.
pub const AUTH_LABEL: &str = "auth";
/// Hex digits of a MAC.
const MAC_HEX: usize = 64;
/// What stands between the counter and the MAC on an `auth` line.
const MAC_SEP: &str = " mac ";
/// The shortest key accepted: 128 bits.
pub const MIN_KEY_LEN: usize = 16;
/// The longest `auth` line, its newline included: what signing may add to a packet.
pub const MAX_LINE: usize = "auth n ".len() + 20 + MAC_SEP.len() + MAC_HEX + 1;

/// A shared secret.
#[derive(Clone)]
pub struct Key(Vec<u8>);

impl std::fmt::Debug for Key {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // A key never reaches a log.
        f.write_str("Key(..)")
    }
}

/// Why a key or an authenticated packet was refused.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum AuthError {
    /// The key is shorter than [`MIN_KEY_LEN`] bytes.
    ShortKey(usize),
    /// The packet has no `auth` line at its end.
    Missing,
    /// The `auth` line is not `auth n N mac M` with M 64 hex digits.
    Malformed,
    /// The MAC does not match the packet under this key.
    WrongMac,
    /// `n` is further from the receiver's clock than it allows.
    Stale,
    /// `n` was seen before from this sender.
    Replayed,
}

impl std::fmt::Display for AuthError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            AuthError::ShortKey(n) => write!(
                f,
                "a key needs at least {MIN_KEY_LEN} bytes, this one has {n} (try `head -c 32 /dev/urandom | base64 > colony.key`)"
            ),
            AuthError::Missing => f.write_str("the packet carries no `auth` line"),
            AuthError::Malformed => f.write_str("the `auth` line is not `auth n N mac <64 hex digits>`"),
            AuthError::WrongMac => f.write_str("the packet's MAC does not match the key"),
            AuthError::Stale => f.write_str("the packet's counter is too far from this clock"),
            AuthError::Replayed => f.write_str("the packet was seen before"),
        }
    }
}

impl std::error::Error for AuthError {}

impl Key {
    /// A key from a key file's bytes; trailing whitespace (a final newline) is not part of it.
    pub fn new(bytes: &[u8]) -> Result<Key, AuthError> {
        let end = bytes
            .iter()
            .rposition(|b| !b.is_ascii_whitespace())
            .map_or(0, |i| i + 1);
        if end < MIN_KEY_LEN {
            return Err(AuthError::ShortKey(end));
        }
        Ok(Key(bytes[..end].to_vec()))
    }

    fn mac(&self, signed: &[u8]) -> [u8; 32] {
        let mut mac =
            <Hmac<Sha256> as Mac>::new_from_slice(&self.0).expect("HMAC takes a key of any length");
        mac.update(signed);
        mac.finalize().into_bytes().into()
    }

    /// Appends the authentication line for counter `n` to a whole packet
    /// (which ends with a newline, as every built packet does).
    pub fn sign(&self, packet: &mut Vec<u8>, n: u64) {
        if packet.last().is_some_and(|&b| b != b'\n') {
            packet.push(b'\n');
        }
        packet.extend_from_slice(format!("{AUTH_LABEL} n {n}{MAC_SEP}").as_bytes());
        let mac = self.mac(packet);
        let mut hex = String::with_capacity(MAC_HEX + 1);
        for b in mac {
            let _ = write!(hex, "{b:02x}");
        }
        hex.push('\n');
        packet.extend_from_slice(hex.as_bytes());
    }

    /// Checks a packet's authentication line; returns the packet without it and its counter.
    pub fn verify<'a>(&self, data: &'a [u8]) -> Result<Signed<'a>, AuthError> {
        let line = split_auth(data).ok_or(AuthError::Missing)?;
        let want = self.mac(&data[..line.mac_at]);
        let got = &data[line.mac_at..line.mac_at + MAC_HEX];
        // Constant time: a MAC compared byte by byte with an early exit leaks
        // how much of a guess was right.
        let mut diff = 0u8;
        for (i, b) in want.iter().enumerate() {
            let hi = hex_digit(got[2 * i]).unwrap_or(0xff);
            let lo = hex_digit(got[2 * i + 1]).unwrap_or(0xff);
            diff |= (hi << 4 | (lo & 0x0f)) ^ b;
            diff |= (hi | lo) & 0xf0;
        }
        if diff != 0 {
            return Err(AuthError::WrongMac);
        }
        Ok(Signed {
            body: &data[..line.start],
            n: line.n,
        })
    }
}

/// An authenticated packet, without its `auth` line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Signed<'a> {
    /// The packet as it was before it was signed.
    pub body: &'a [u8],
    /// The sender's counter.
    pub n: u64,
}

struct AuthLine {
    start: usize,
    n: u64,
    mac_at: usize,
}

fn hex_digit(b: u8) -> Option<u8> {
    match b {
        b'0'..=b'9' => Some(b - b'0'),
        b'a'..=b'f' => Some(b - b'a' + 10),
        _ => None,
    }
}

/// Finds a well-formed `auth n N mac M` as the packet's last line.
fn split_auth(data: &[u8]) -> Option<AuthLine> {
    let text = data.strip_suffix(b"\n").unwrap_or(data);
    // A signed packet ends with ` mac ` and the MAC. Looking there first
    // tells almost every unsigned packet apart without scanning its last
    // line back to its start (which a hub with no key did for every packet).
    let sep = text.len().checked_sub(MAC_HEX + MAC_SEP.len())?;
    if &text[sep..sep + MAC_SEP.len()] != MAC_SEP.as_bytes() {
        return None;
    }
    let start = text.iter().rposition(|&b| b == b'\n')? + 1;
    let line = std::str::from_utf8(&text[start..]).ok()?;
    let rest = line.strip_prefix(AUTH_LABEL)?.strip_prefix(" n ")?;
    let (n, mac) = rest.split_once(MAC_SEP)?;
    if mac.len() != MAC_HEX || !mac.bytes().all(|b| hex_digit(b).is_some()) {
        return None;
    }
    if n.is_empty() || !n.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    Some(AuthLine {
        start,
        n: n.parse().ok()?,
        mac_at: start + line.len() - MAC_HEX,
    })
}

/// The packet without a trailing `auth` line, whether or not its MAC is right;
/// `None` when it has none. A hub with no key forwards packets this way, so
/// that a signing client can talk to it.
pub fn strip_auth(data: &[u8]) -> Option<&[u8]> {
    split_auth(data).map(|l| &data[..l.start])
}

/// Whether the packet ends with something that claims to be an `auth` line
/// (well-formed or not).
pub fn has_auth_label(data: &[u8]) -> bool {
    let text = data.strip_suffix(b"\n").unwrap_or(data);
    let start = text.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
    text[start..].starts_with(b"auth ")
}

/// Microseconds since the UNIX epoch, the clock behind `n`.
pub fn unix_micros(now: SystemTime) -> u64 {
    now.duration_since(UNIX_EPOCH)
        .map_or(0, |d| u64::try_from(d.as_micros()).unwrap_or(u64::MAX))
}

/// A sender's side: its key and its counter.
#[derive(Debug, Clone)]
pub struct Signer {
    key: Key,
    last: u64,
}

impl Signer {
    /// Signs with `key`.
    pub fn new(key: Key) -> Signer {
        Signer { key, last: 0 }
    }

    /// Appends an authentication line, with a counter above every one before.
    pub fn sign(&mut self, packet: &mut Vec<u8>, now: SystemTime) {
        self.last = unix_micros(now).max(self.last.saturating_add(1));
        self.key.sign(packet, self.last);
    }
}

/// The counters one sender used lately: the highest and a bitmap of the 64
/// below it (IPsec's and DTLS's window), so packets reordered in flight are
/// still taken but none twice.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ReplayWindow {
    highest: u64,
    seen: u64,
}

impl ReplayWindow {
    /// Records `n`; `false` when it was seen or is too old to tell.
    pub fn accept(&mut self, n: u64) -> bool {
        if n > self.highest {
            let shift = n - self.highest;
            self.seen = if shift >= 64 { 0 } else { self.seen << shift };
            self.seen |= 1;
            self.highest = n;
            return true;
        }
        let back = self.highest - n;
        if back >= 64 || self.seen & (1 << back) != 0 {
            return false;
        }
        self.seen |= 1 << back;
        true
    }

    /// The highest counter accepted.
    pub fn highest(&self) -> u64 {
        self.highest
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key() -> Key {
        Key::new(b"0123456789abcdef-a-test-key\n").unwrap()
    }

    #[test]
    fn a_signed_packet_verifies_and_gives_back_its_body() {
        let body = b"@ <hub> 0\nmin_priority value 5\n".to_vec();
        let mut p = body.clone();
        key().sign(&mut p, 42);
        let signed = key().verify(&p).unwrap();
        assert_eq!(signed.body, &body[..]);
        assert_eq!(signed.n, 42);
        assert!(
            crate::Packet::parse(&p).is_ok(),
            "the auth line is a line of the format"
        );
        assert_eq!(strip_auth(&p), Some(&body[..]));
    }

    #[test]
    fn the_mac_matches_an_independent_hmac_sha256() {
        // HMAC-SHA256 per RFC 4231 test case 2 (key "Jefe" is too short for a
        // colony key, so the primitive is checked directly).
        let mut mac = <Hmac<Sha256> as Mac>::new_from_slice(b"Jefe").unwrap();
        mac.update(b"what do ya want for nothing?");
        let hex: String = mac
            .finalize()
            .into_bytes()
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect();
        assert_eq!(
            hex,
            "5bdcc146bf60754e6a042426089575c75a003f089d2739839dec58b964ec3843"
        );
    }

    #[test]
    fn any_change_to_a_signed_packet_is_refused() {
        let mut p = b"@ <hub> 0\nmin_priority value 5\n".to_vec();
        key().sign(&mut p, 7);
        for i in 0..p.len() {
            let mut bad = p.clone();
            bad[i] ^= 0x01;
            assert!(
                key().verify(&bad).is_err(),
                "byte {i} flipped still verified"
            );
        }
        let other = Key::new(b"another key, 16 bytes or more").unwrap();
        assert_eq!(other.verify(&p), Err(AuthError::WrongMac));
        assert_eq!(
            key().verify(b"@ <hub> 0\nstatus\n"),
            Err(AuthError::Missing)
        );
    }

    /// `strip_auth` as it was before it looked at the packet's end first.
    fn strip_auth_by_the_last_line(data: &[u8]) -> Option<&[u8]> {
        let text = data.strip_suffix(b"\n").unwrap_or(data);
        let start = text.iter().rposition(|&b| b == b'\n')? + 1;
        let line = std::str::from_utf8(&text[start..]).ok()?;
        let rest = line.strip_prefix(AUTH_LABEL)?.strip_prefix(" n ")?;
        let (n, mac) = rest.split_once(" mac ")?;
        let hex = mac.len() == MAC_HEX && mac.bytes().all(|b| hex_digit(b).is_some());
        let digits = !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit());
        (hex && digits && n.parse::<u64>().is_ok()).then(|| &data[..start])
    }

    proptest::proptest! {
        #[test]
        fn looking_at_the_end_first_changes_no_answer(
            body in "[ -~\n]{0,80}",
            // Mostly what a signer writes (so the rule accepts about half of
            // the cases), the rest near misses.
            n in "[0-9]{1,19}|[0-9x]{0,22}",
            sep in proptest::sample::select(vec![" mac ", " mac ", " mac ", " mac", "mac ", "  mac ", " mac  "]),
            mac in "[0-9a-f]{64}|[0-9a-f]{62,66}|[0-9a-fG]{64}",
            newline in proptest::bool::ANY,
        ) {
            let end = if newline { "\n" } else { "" };
            let text = format!("{body}\nauth n {n}{sep}{mac}{end}");
            proptest::prop_assert_eq!(
                strip_auth(text.as_bytes()),
                strip_auth_by_the_last_line(text.as_bytes())
            );
            // And a signed packet is still found.
            let mut signed = format!("@ <a> 0\n{}", body.replace('@', "x")).into_bytes();
            key().sign(&mut signed, 9);
            proptest::prop_assert!(strip_auth(&signed).is_some());
            proptest::prop_assert_eq!(strip_auth(&signed), strip_auth_by_the_last_line(&signed));
        }
    }

    #[test]
    fn short_keys_are_refused() {
        assert_eq!(Key::new(b"short\n").unwrap_err(), AuthError::ShortKey(5));
        assert!(Key::new(b"                    ").is_err());
    }

    #[test]
    fn a_signer_never_repeats_a_counter() {
        let mut s = Signer::new(key());
        let t = UNIX_EPOCH + std::time::Duration::from_secs(1000);
        let mut last = 0;
        for _ in 0..5 {
            let mut p = b"@ <a> 0\nx\n".to_vec();
            s.sign(&mut p, t);
            let n = key().verify(&p).unwrap().n;
            assert!(n > last);
            last = n;
        }
    }

    #[test]
    fn the_replay_window_takes_each_counter_once() {
        let mut w = ReplayWindow::default();
        assert!(w.accept(10));
        assert!(!w.accept(10));
        assert!(w.accept(12));
        assert!(w.accept(11), "reordered, inside the window");
        assert!(!w.accept(11));
        assert!(w.accept(200));
        assert!(!w.accept(12), "too old to tell");
        assert!(w.accept(199));
    }
}
