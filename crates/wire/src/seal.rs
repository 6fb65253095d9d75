//! Packets that prove which process wrote them: an Ed25519 signature under a
//! key the process made for itself.
//!
//! A sealed packet ends with one more line:
//!
//! ```text
//! @ <murdoch.user.17.1> 0
//! done task 17 bidder r2
//! seal n 5 key 3d4017c3…(64 hex digits) sig 9f51…(128 hex digits)
//! ```
//!
//! `sig` is the Ed25519 signature, under `key`, of every byte before its
//! value (the header, the body and `seal n N key K sig ` itself). `n` counts
//! the packets the key sealed, so a receiver that remembers the highest it
//! took from a key refuses a copy sent again ([`Counter`]).
//!
//! [`auth`](crate::auth) proves a packet came from *some* holder of a shared
//! key, and the hub strips it; a seal travels end to end, through the hub and
//! bridges, and proves *which* process wrote the packet. Protocols above the
//! hub bind what they hand out to the key that asked for it (a MURDOCH task to
//! the key that won it, a call's answer to the provider the call went to), so
//! nobody else can act for that process. Keys are made per process
//! ([`Identity::generate`]): they name a process, not a person, and need no
//! distribution. Being sealed proves nothing about *who may* take part; a hub
//! run with `--auth-all` bounds that to holders of its key.

use std::fmt::{self, Write as _};

use ed25519_dalek::{Signature, Signer as _, SigningKey, VerifyingKey};
use sha2::{Digest, Sha256};

/// The label of the seal line.
pub const SEAL_LABEL: &str = "seal";
const KEY_HEX: usize = 64;
const SIG_HEX: usize = 128;
const KEY_SEP: &str = " key ";
const SIG_SEP: &str = " sig ";
const HEAD: &str = "seal n ";
/// The most digits of a `u64`.
const MAX_N_DIGITS: usize = 20;
/// The longest seal line, its newline included: what sealing may add to a packet.
pub const MAX_LINE: usize =
    HEAD.len() + MAX_N_DIGITS + KEY_SEP.len() + KEY_HEX + SIG_SEP.len() + SIG_HEX + 1;

/// Why a seal was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SealError {
    /// The packet's last line is no `seal` line.
    Missing,
    /// The last line is not `seal n N key <64 hex> sig <128 hex>`.
    Malformed,
    /// The key is no Ed25519 public key.
    BadKey,
    /// The signature does not match the packet under its key.
    BadSignature,
}

impl fmt::Display for SealError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            SealError::Missing => "the packet is not sealed",
            SealError::Malformed => {
                "the `seal` line is not `seal n N key <64 hex digits> sig <128 hex digits>`"
            }
            SealError::BadKey => "the seal's key is not an Ed25519 public key",
            SealError::BadSignature => "the seal's signature does not match the packet",
        })
    }
}

impl std::error::Error for SealError {}

/// A process's public key: what names it on the wire.
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct PublicKey([u8; 32]);

impl PublicKey {
    /// The key's first 64 bits of SHA-256: a short name for it (a provider's
    /// id). Finding another key with the same fingerprint takes about 2^64 tries.
    pub fn fingerprint(&self) -> u64 {
        let digest = Sha256::digest(self.0);
        let mut first = [0u8; 8];
        first.copy_from_slice(&digest[..8]);
        u64::from_be_bytes(first)
    }

    /// The key's 32 bytes.
    pub fn as_bytes(&self) -> &[u8; 32] {
        &self.0
    }

    /// Reads 64 lowercase hex digits.
    pub fn parse(hex: &str) -> Option<PublicKey> {
        let mut bytes = [0u8; 32];
        decode_hex(hex.as_bytes(), &mut bytes)?;
        Some(PublicKey(bytes))
    }
}

impl fmt::Display for PublicKey {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for b in self.0 {
            write!(f, "{b:02x}")?;
        }
        Ok(())
    }
}

impl fmt::Debug for PublicKey {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "PublicKey({self})")
    }
}

/// A process's signing key and the count of packets it sealed.
#[derive(Clone)]
pub struct Identity {
    key: SigningKey,
    public: PublicKey,
    sealed: u64,
}

impl fmt::Debug for Identity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // The secret never reaches a log.
        write!(f, "Identity({})", self.public)
    }
}

impl Identity {
    /// A new key from the operating system's randomness.
    pub fn generate() -> Identity {
        let mut seed = [0u8; 32];
        if getrandom::fill(&mut seed).is_err() {
            // No system randomness (not seen on any platform colony runs on):
            // std's hash keys are seeded from it where it exists at all.
            use std::hash::{BuildHasher, Hasher};
            for chunk in seed.chunks_mut(8) {
                let mut h = std::collections::hash_map::RandomState::new().build_hasher();
                h.write_u128(
                    std::time::SystemTime::now()
                        .duration_since(std::time::UNIX_EPOCH)
                        .map_or(0, |d| d.as_nanos()),
                );
                chunk.copy_from_slice(&h.finish().to_le_bytes());
            }
        }
        Identity::from_seed(seed)
    }

    /// The key a seed gives, for runs that must repeat exactly.
    pub fn from_seed(seed: [u8; 32]) -> Identity {
        let key = SigningKey::from_bytes(&seed);
        let public = PublicKey(key.verifying_key().to_bytes());
        Identity {
            key,
            public,
            sealed: 0,
        }
    }

    /// The public key that names it.
    pub fn public(&self) -> PublicKey {
        self.public
    }

    /// Appends the seal line to a whole packet (one ending with a newline, as
    /// every built packet does), counting it.
    pub fn seal(&mut self, packet: &mut Vec<u8>) {
        if packet.last().is_some_and(|&b| b != b'\n') {
            packet.push(b'\n');
        }
        self.sealed += 1;
        let mut head = format!("{HEAD}{}{KEY_SEP}", self.sealed);
        let _ = write!(head, "{}{SIG_SEP}", self.public);
        packet.extend_from_slice(head.as_bytes());
        let sig = self.key.sign(packet).to_bytes();
        let mut hex = String::with_capacity(SIG_HEX + 1);
        for b in sig {
            let _ = write!(hex, "{b:02x}");
        }
        hex.push('\n');
        packet.extend_from_slice(hex.as_bytes());
    }

    /// A sealed copy of `packet`.
    pub fn sealed(&mut self, mut packet: Vec<u8>) -> Vec<u8> {
        self.seal(&mut packet);
        packet
    }
}

/// A packet whose seal checked out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Sealed<'a> {
    /// The packet as it was before it was sealed.
    pub body: &'a [u8],
    /// Who sealed it.
    pub key: PublicKey,
    /// Its count among the packets that key sealed.
    pub n: u64,
}

struct SealLine {
    start: usize,
    n: u64,
    key: [u8; 32],
    sig: [u8; 64],
    sig_at: usize,
}

fn hex_digit(b: u8) -> Option<u8> {
    match b {
        b'0'..=b'9' => Some(b - b'0'),
        b'a'..=b'f' => Some(b - b'a' + 10),
        _ => None,
    }
}

fn decode_hex(hex: &[u8], out: &mut [u8]) -> Option<()> {
    if hex.len() != out.len() * 2 {
        return None;
    }
    for (o, pair) in out.iter_mut().zip(hex.chunks_exact(2)) {
        *o = hex_digit(pair[0])? << 4 | hex_digit(pair[1])?;
    }
    Some(())
}

/// Finds a well-formed seal line at the packet's end, reading only its last
/// few hundred bytes.
fn split_seal(data: &[u8]) -> Result<SealLine, SealError> {
    let text = data.strip_suffix(b"\n").unwrap_or(data);
    let sig_at = text.len().checked_sub(SIG_HEX).ok_or(SealError::Missing)?;
    let key_at = sig_at
        .checked_sub(SIG_SEP.len() + KEY_HEX)
        .ok_or(SealError::Missing)?;
    let n_end = key_at
        .checked_sub(KEY_SEP.len())
        .ok_or(SealError::Missing)?;
    if &text[sig_at - SIG_SEP.len()..sig_at] != SIG_SEP.as_bytes()
        || &text[n_end..key_at] != KEY_SEP.as_bytes()
    {
        return Err(SealError::Missing);
    }
    let digits = text[..n_end]
        .iter()
        .rev()
        .take_while(|b| b.is_ascii_digit())
        .count();
    let n_at = n_end - digits;
    let start = n_at.checked_sub(HEAD.len()).ok_or(SealError::Missing)?;
    if &text[start..n_at] != HEAD.as_bytes() || (start > 0 && text[start - 1] != b'\n') {
        return Err(SealError::Missing);
    }
    if digits == 0 || digits > MAX_N_DIGITS || (digits > 1 && text[n_at] == b'0') {
        return Err(SealError::Malformed);
    }
    let n = std::str::from_utf8(&text[n_at..n_end])
        .ok()
        .and_then(|s| s.parse().ok())
        .ok_or(SealError::Malformed)?;
    let mut key = [0u8; 32];
    decode_hex(&text[key_at..key_at + KEY_HEX], &mut key).ok_or(SealError::Malformed)?;
    let mut sig = [0u8; 64];
    decode_hex(&text[sig_at..], &mut sig).ok_or(SealError::Malformed)?;
    Ok(SealLine {
        start,
        n,
        key,
        sig,
        sig_at,
    })
}

/// Checks a packet's seal; returns the packet without it, who sealed it and
/// its count.
pub fn open(data: &[u8]) -> Result<Sealed<'_>, SealError> {
    let line = split_seal(data)?;
    let key = VerifyingKey::from_bytes(&line.key).map_err(|_| SealError::BadKey)?;
    // Strict: no small-order keys and no malleable signatures, so one packet
    // has exactly one valid seal under a key.
    key.verify_strict(&data[..line.sig_at], &Signature::from_bytes(&line.sig))
        .map_err(|_| SealError::BadSignature)?;
    Ok(Sealed {
        body: &data[..line.start],
        key: PublicKey(line.key),
        n: line.n,
    })
}

/// The packet without a trailing seal line, unchecked; the packet itself when
/// it has none. For readers that only show what a packet says.
pub fn strip(data: &[u8]) -> &[u8] {
    split_seal(data).map_or(data, |l| &data[..l.start])
}

/// The highest count taken from one key: a sealed packet sent again, or an
/// older one, is refused.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counter(u64);

impl Counter {
    /// Takes `n` if it is above every count taken before.
    pub fn accept(&mut self, n: u64) -> bool {
        if n > self.0 {
            self.0 = n;
            true
        } else {
            false
        }
    }
}

/// A role bound to the key that first took it (a task's announcer, its
/// winner), and the count of the last packet taken from that key: a protocol
/// takes the role's packets only from that key, each once and in order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Binding {
    key: PublicKey,
    heard: Counter,
}

impl Binding {
    /// The role bound to `key`, its packet `n` taken.
    pub fn new(key: PublicKey, n: u64) -> Binding {
        let mut heard = Counter::default();
        heard.accept(n);
        Binding { key, heard }
    }

    /// The key bound.
    pub fn key(&self) -> PublicKey {
        self.key
    }

    /// Whether a packet sealed by `key` with count `n` speaks for the role:
    /// the bound key's, and newer than any taken before (a copy sent again
    /// is not). Taking it counts it.
    pub fn speaks(&mut self, key: PublicKey, n: u64) -> bool {
        key == self.key && self.heard.accept(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ed25519_dalek::Verifier as _;

    const PACKET: &[u8] = b"@ <murdoch.user.17.1> 0\ndone task 17 bidder r2\n";

    fn identity(seed: u8) -> Identity {
        Identity::from_seed([seed; 32])
    }

    #[test]
    fn a_sealed_packet_opens_to_its_body_and_key() {
        let mut id = identity(1);
        let sealed = id.sealed(PACKET.to_vec());
        let opened = open(&sealed).unwrap();
        assert_eq!(opened.body, PACKET);
        assert_eq!(opened.key, id.public());
        assert_eq!(opened.n, 1);
        assert_eq!(open(&id.sealed(PACKET.to_vec())).unwrap().n, 2);
        assert_eq!(strip(&sealed), PACKET);
        // A sealed packet is still a packet, its seal an ordinary last line.
        let p = crate::Packet::parse(&sealed).unwrap();
        assert_eq!(p.lines().last().unwrap().label(), SEAL_LABEL);
    }

    #[test]
    fn the_signature_matches_an_independent_ed25519_verifier() {
        let mut id = identity(2);
        let sealed = id.sealed(PACKET.to_vec());
        let text = std::str::from_utf8(&sealed).unwrap();
        let sig_hex = text.trim_end().rsplit(' ').next().unwrap();
        let mut sig = [0u8; 64];
        decode_hex(sig_hex.as_bytes(), &mut sig).unwrap();
        let signed = &sealed[..sealed.len() - SIG_HEX - 1];
        let key = VerifyingKey::from_bytes(id.public().as_bytes()).unwrap();
        key.verify(signed, &Signature::from_bytes(&sig)).unwrap();
    }

    #[test]
    fn any_change_to_a_sealed_packet_is_refused() {
        let mut id = identity(3);
        let sealed = id.sealed(PACKET.to_vec());
        for i in 0..sealed.len() - 1 {
            let mut bad = sealed.clone();
            bad[i] ^= 0x01;
            match open(&bad) {
                Ok(s) => panic!("byte {i} changed and still opened as {s:?}"),
                // A change to the packet itself is caught by the signature;
                // one to the seal line's framing leaves no seal at all.
                Err(e) if i + 1 < PACKET.len() => {
                    assert_eq!(e, SealError::BadSignature, "byte {i}")
                }
                Err(_) => {}
            }
        }
    }

    #[test]
    fn another_key_cannot_take_a_seal_over() {
        let mut real = identity(4);
        let forger = identity(5);
        let sealed = String::from_utf8(real.sealed(PACKET.to_vec())).unwrap();
        // The forger swaps in its own key, keeping the real signature.
        let forged = sealed.replace(&real.public().to_string(), &forger.public().to_string());
        assert_eq!(open(forged.as_bytes()), Err(SealError::BadSignature));
    }

    #[test]
    fn unsealed_and_malformed_lines_are_told_apart() {
        assert_eq!(open(PACKET), Err(SealError::Missing));
        assert_eq!(strip(PACKET), PACKET);
        let key = "0".repeat(64);
        let sig = "0".repeat(128);
        let cases = [
            (
                format!("seal n 01 key {key} sig {sig}\n"),
                SealError::Malformed,
            ),
            (
                format!("seal n 1 key {key} sig {sig}\n"),
                SealError::BadSignature,
            ),
            (
                format!("seal n 1 key {} sig {sig}\n", "G".repeat(64)),
                SealError::Malformed,
            ),
            (
                format!("xseal n 1 key {key} sig {sig}\n"),
                SealError::Missing,
            ),
            (
                format!("seal n  key {key} sig {sig}\n"),
                SealError::Malformed,
            ),
        ];
        for (line, want) in cases {
            let mut packet = PACKET.to_vec();
            packet.extend_from_slice(line.as_bytes());
            let got = open(&packet).err();
            // An all-zero key is a small-order point: refused as a key.
            assert!(
                got == Some(want)
                    || (want == SealError::BadSignature && got == Some(SealError::BadKey)),
                "{line}: {got:?}"
            );
        }
    }

    #[test]
    fn no_seal_line_is_longer_than_max_line() {
        let mut id = identity(6);
        id.sealed = u64::MAX - 1;
        let sealed = id.sealed(PACKET.to_vec());
        assert_eq!(sealed.len() - PACKET.len(), MAX_LINE);
        assert_eq!(open(&sealed).unwrap().n, u64::MAX);
    }

    #[test]
    fn a_binding_takes_its_own_key_once_per_count() {
        let (a, b) = (identity(8).public(), identity(9).public());
        let mut bound = Binding::new(a, 3);
        assert!(!bound.speaks(a, 3), "the packet that bound it, again");
        assert!(!bound.speaks(b, 4), "another key");
        assert!(bound.speaks(a, 4));
        assert!(!bound.speaks(a, 2));
        assert_eq!(bound.key(), a);
    }

    #[test]
    fn a_counter_takes_each_count_once_and_in_order() {
        let mut c = Counter::default();
        assert!(c.accept(1));
        assert!(!c.accept(1));
        assert!(c.accept(5));
        assert!(!c.accept(3));
    }

    proptest::proptest! {
        #[test]
        fn opening_any_bytes_never_panics(data in proptest::collection::vec(proptest::num::u8::ANY, 0..400)) {
            let _ = open(&data);
            let _ = strip(&data);
        }

        #[test]
        fn any_body_seals_and_opens_again(body in "[a-z]{1,8}( [a-z]{1,8} [0-9]{1,6}){0,4}", seed in proptest::num::u8::ANY) {
            let mut id = identity(seed);
            let packet = format!("@ <x> 0\n{body}\n").into_bytes();
            let sealed = id.sealed(packet.clone());
            let opened = open(&sealed).unwrap();
            proptest::prop_assert_eq!(opened.body, &packet[..]);
            proptest::prop_assert_eq!(opened.key, id.public());
        }
    }
}
