//! The benchmark packet: a valid colony packet of exactly [`LEN`] bytes whose
//! sequence number sits at a fixed offset, so stamping and reading it costs
//! no parsing on either side of the broker under test.

/// Bytes in every benchmark packet (the MQTT runs carry the same bytes as payload).
pub const LEN: usize = 100;
/// The channel (colony) and topic (MQTT) the benchmark publishes on.
pub const CHANNEL: &str = "bench";

const HEAD: &str = "@ <bench> 0\nping seq ";
const DIGITS: usize = 10;
const SEQ_AT: usize = HEAD.len();
const PAD_OPEN: &str = " pad \"";
const TAIL: &str = "\"\n";

/// A 100-byte packet template; [`Packet::stamp`] writes a sequence number into it.
#[derive(Clone)]
pub struct Packet {
    bytes: [u8; LEN],
}

impl Packet {
    pub fn new() -> Packet {
        let pad = LEN - HEAD.len() - DIGITS - PAD_OPEN.len() - TAIL.len();
        let text = format!(
            "{HEAD}{:0w$}{PAD_OPEN}{}{TAIL}",
            0,
            "x".repeat(pad),
            w = DIGITS
        );
        let mut bytes = [0u8; LEN];
        bytes.copy_from_slice(text.as_bytes());
        Packet { bytes }
    }

    /// Writes `seq` (zero-padded, ten digits) into the packet.
    pub fn stamp(&mut self, mut seq: u64) -> &[u8; LEN] {
        for i in (0..DIGITS).rev() {
            self.bytes[SEQ_AT + i] = b'0' + (seq % 10) as u8;
            seq /= 10;
        }
        &self.bytes
    }

    pub fn bytes(&self) -> &[u8; LEN] {
        &self.bytes
    }
}

impl Default for Packet {
    fn default() -> Self {
        Packet::new()
    }
}

/// The sequence number of a benchmark packet, or `None` for anything else.
pub fn seq_of(data: &[u8]) -> Option<u64> {
    if data.len() != LEN || !data.starts_with(HEAD.as_bytes()) {
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
        let bytes = *p.stamp(1_234_567);
        assert_eq!(bytes.len(), 100);
        let parsed = colony_wire::Packet::parse(&bytes).expect("valid colony packet");
        assert!(parsed.has_subject(CHANNEL));
        let line = parsed.line("ping").expect("ping line");
        assert_eq!(line.i64("seq").unwrap(), 1_234_567);
        assert_eq!(seq_of(&bytes), Some(1_234_567));
        assert_eq!(seq_of(&bytes[..99]), None);
    }
}
