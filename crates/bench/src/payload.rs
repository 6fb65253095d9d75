//! The benchmark packet: a valid colony packet whose sequence number sits at
//! a fixed offset, so stamping and reading it costs no parsing on either
//! side of the broker under test. Its length is [`LEN`] bytes, or with
//! [`Lengths::Mixed`] anything from 60 to 400 bytes, chosen from the
//! sequence number, so neighbours almost never share a length.

use std::ops::RangeInclusive;

/// Bytes in every fixed-length benchmark packet (the MQTT runs carry the same bytes as payload).
pub const LEN: usize = 100;
/// The lengths of mixed-length packets.
pub const MIXED: RangeInclusive<usize> = 60..=400;
/// The channel (colony) and topic (MQTT) the benchmark publishes on.
pub const CHANNEL: &str = "bench";

const HEAD: &str = "@ <bench> 0\nping seq ";
const DIGITS: usize = 10;
const SEQ_AT: usize = HEAD.len();
const PAD_OPEN: &str = " pad \"";
const PAD_AT: usize = SEQ_AT + DIGITS + PAD_OPEN.len();
const TAIL: &str = "\"\n";
const MAX_LEN: usize = *MIXED.end();

/// Which lengths the packets of a run have.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lengths {
    /// Every packet [`LEN`] bytes: the case UDP GSO is made for.
    Fixed,
    /// Uniformly 60 to 400 bytes, differing from packet to packet.
    Mixed,
}

impl Lengths {
    /// The length of packet `seq`.
    pub fn len_of(self, seq: u64) -> usize {
        match self {
            Lengths::Fixed => LEN,
            Lengths::Mixed => {
                // A multiplicative hash: uniform enough, and the same on
                // every run.
                let h = seq.wrapping_add(1).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 32;
                let span = (MIXED.end() - MIXED.start() + 1) as u64;
                MIXED.start() + (h % span) as usize
            }
        }
    }

    /// The packets, in words, for the report.
    pub fn describe(self) -> &'static str {
        match self {
            Lengths::Fixed => "100-byte packets",
            Lengths::Mixed => {
                "packets of 60 to 400 bytes (uniform, a different length from packet to packet)"
            }
        }
    }
}

/// A packet template; [`Packet::stamp`] writes a sequence number into it
/// (and gives it that packet's length).
#[derive(Clone)]
pub struct Packet {
    bytes: [u8; MAX_LEN],
    len: usize,
    lengths: Lengths,
}

impl Packet {
    /// A fixed-length packet.
    pub fn new() -> Packet {
        Packet::with(Lengths::Fixed)
    }

    pub fn with(lengths: Lengths) -> Packet {
        let mut bytes = [b'x'; MAX_LEN];
        bytes[..SEQ_AT].copy_from_slice(HEAD.as_bytes());
        bytes[SEQ_AT..SEQ_AT + DIGITS].fill(b'0');
        bytes[SEQ_AT + DIGITS..PAD_AT].copy_from_slice(PAD_OPEN.as_bytes());
        let mut p = Packet {
            bytes,
            len: MAX_LEN,
            lengths,
        };
        p.set_len(lengths.len_of(0));
        p
    }

    fn set_len(&mut self, len: usize) {
        if len == self.len {
            return;
        }
        // The old tail becomes padding, and the new one goes at the end.
        let old = self.len;
        self.bytes[old - TAIL.len()..old].fill(b'x');
        self.bytes[len - TAIL.len()..len].copy_from_slice(TAIL.as_bytes());
        self.len = len;
    }

    /// Writes `seq` (zero-padded, ten digits) into the packet.
    pub fn stamp(&mut self, mut seq: u64) -> &[u8] {
        self.set_len(self.lengths.len_of(seq));
        for i in (0..DIGITS).rev() {
            self.bytes[SEQ_AT + i] = b'0' + (seq % 10) as u8;
            seq /= 10;
        }
        &self.bytes[..self.len]
    }

    pub fn bytes(&self) -> &[u8] {
        &self.bytes[..self.len]
    }
}

impl Default for Packet {
    fn default() -> Self {
        Packet::new()
    }
}

/// The sequence number of a benchmark packet, or `None` for anything else.
pub fn seq_of(data: &[u8]) -> Option<u64> {
    if data.len() < PAD_AT + TAIL.len()
        || data.len() > MAX_LEN
        || !data.starts_with(HEAD.as_bytes())
    {
        return None;
    }
    let mut seq = 0u64;
    for &d in &data[SEQ_AT..SEQ_AT + DIGITS] {
        if !d.is_ascii_digit() {
            return None;
        }
        seq = seq * 10 + u64::from(d - b'0');
    }
    Some(seq)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packet_is_exactly_100_bytes_and_valid() {
        let mut p = Packet::new();
        let bytes = p.stamp(1_234_567).to_vec();
        assert_eq!(bytes.len(), 100);
        let parsed = colony_wire::Packet::parse(&bytes).expect("valid colony packet");
        assert!(parsed.has_subject(CHANNEL));
        let line = parsed.line("ping").expect("ping line");
        assert_eq!(line.i64("seq").unwrap(), 1_234_567);
        assert_eq!(seq_of(&bytes), Some(1_234_567));
        assert_eq!(seq_of(&bytes[..30]), None);
    }

    #[test]
    fn mixed_packets_are_valid_and_of_many_lengths() {
        let mut p = Packet::with(Lengths::Mixed);
        let mut lengths = std::collections::HashSet::new();
        for seq in 0..5_000 {
            let bytes = p.stamp(seq).to_vec();
            assert!(MIXED.contains(&bytes.len()));
            lengths.insert(bytes.len());
            let parsed = colony_wire::Packet::parse(&bytes).expect("valid colony packet");
            assert_eq!(parsed.line("ping").unwrap().i64("seq").unwrap(), seq as i64);
            assert_eq!(seq_of(&bytes), Some(seq));
        }
        assert!(lengths.len() > 300, "{} lengths", lengths.len());
    }
}
