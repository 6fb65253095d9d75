//! Several packets in one datagram, for a subscriber that asked the hub for
//! them ([`Request::Batch`](crate::Request::Batch)).
//!
//! ```text
//! % 22 26
//! @ <vision> 0
//! ball x 1
//! @ <vision> 0
//! ball x 1.5
//! ```
//!
//! The first line, the head, starts with `%` and gives each packet's length
//! in bytes; the packets follow byte for byte, and end exactly where the
//! datagram does. The lengths are needed: a body line may itself start with
//! `@` (a bare label), so cutting at header lines would let a publisher hide
//! a packet of its own choosing, on any subject and at any priority, inside
//! the one it sent. A datagram that does not start with `%` is one packet, as
//! every datagram was before batching.

use std::fmt;
use std::ops::Range;

/// The byte a batched datagram starts with; no packet does (a packet's first
/// byte is `@`).
pub const BATCH_MARK: u8 = b'%';

/// Bytes of a head that names no packet: the mark and the line end.
pub const HEAD_BASE: usize = 2;

/// The bytes one packet of `len` bytes adds to the head: a space and its
/// length in decimal.
pub fn head_cost(len: usize) -> usize {
    1 + digits(len)
}

fn digits(mut n: usize) -> usize {
    let mut d = 1;
    while n >= 10 {
        n /= 10;
        d += 1;
    }
    d
}

/// Writes the head for packets of these lengths (`% 22 26\n`), exactly
/// [`HEAD_BASE`] plus each length's [`head_cost`] bytes long. Each length is
/// 1 to [`MAX_PACKET`](crate::MAX_PACKET): no packet is shorter or longer,
/// and [`split`] refuses any other.
pub fn write_head(lengths: &[usize], out: &mut Vec<u8>) {
    out.push(BATCH_MARK);
    for &len in lengths {
        debug_assert!(
            (1..=crate::MAX_PACKET).contains(&len),
            "a packet of {len} bytes"
        );
        out.push(b' ');
        let start = out.len();
        let mut n = len;
        loop {
            out.push(b'0' + (n % 10) as u8);
            n /= 10;
            if n == 0 {
                break;
            }
        }
        out[start..].reverse();
    }
    out.push(b'\n');
}

/// Joins packets into one batched datagram: the head, then each packet.
pub fn join(packets: &[&[u8]]) -> Vec<u8> {
    let lengths: Vec<usize> = packets.iter().map(|p| p.len()).collect();
    let mut out =
        Vec::with_capacity(HEAD_BASE + lengths.iter().map(|&l| head_cost(l) + l).sum::<usize>());
    write_head(&lengths, &mut out);
    for p in packets {
        out.extend_from_slice(p);
    }
    out
}

/// Why a datagram that starts with `%` is no batch.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum BatchError {
    /// The head has no line end.
    UnendedHead,
    /// Something in the head is not a length: the byte offset where it starts.
    BadLength {
        /// Offset of the offending token in the datagram.
        at: usize,
    },
    /// The head names no packet.
    NoPackets,
    /// The lengths do not add up to what follows the head.
    WrongTotal {
        /// Bytes the head names.
        named: usize,
        /// Bytes that follow it.
        present: usize,
    },
}

impl fmt::Display for BatchError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BatchError::UnendedHead => write!(f, "a batch's head (`% ...`) has no line end"),
            BatchError::BadLength { at } => write!(
                f,
                "byte {at}: a batch's head holds lengths of 1 to 65507 bytes, one space apart"
            ),
            BatchError::NoPackets => write!(f, "a batch's head names no packet"),
            BatchError::WrongTotal { named, present } => write!(
                f,
                "a batch's head names {named} bytes of packets, but {present} follow it"
            ),
        }
    }
}

impl std::error::Error for BatchError {}

/// Where each packet of a datagram lies in it: one range for a plain packet,
/// one per packet for a batch. Every length is checked before the first range
/// is given, so a damaged batch yields nothing.
///
/// ```
/// use colony_wire::batch::{join, split};
/// let d = join(&[b"@ <a> 0\nx y 1\n", b"@ <b> 1\n"]);
/// let pieces: Vec<&[u8]> = split(&d).unwrap().map(|r| &d[r]).collect();
/// assert_eq!(pieces, [&b"@ <a> 0\nx y 1\n"[..], b"@ <b> 1\n"]);
/// assert_eq!(split(b"@ <a> 0\n").unwrap().count(), 1);
/// ```
pub fn split(datagram: &[u8]) -> Result<Pieces<'_>, BatchError> {
    if datagram.first() != Some(&BATCH_MARK) {
        return Ok(Pieces {
            head: &[],
            at: 0,
            body: 0..datagram.len(),
            single: true,
        });
    }
    let end = datagram
        .iter()
        .position(|&b| b == b'\n')
        .ok_or(BatchError::UnendedHead)?;
    let head = &datagram[1..end];
    let body = end + 1..datagram.len();
    if head.first().is_some_and(|&b| b != b' ') {
        return Err(BatchError::BadLength { at: 1 });
    }
    let mut named = 0usize;
    let mut count = 0usize;
    let mut at = 1;
    for token in head.split(|&b| b == b' ').skip(1) {
        // `head` starts with the space after the mark, so each token follows one space.
        at += 1;
        let len = parse_length(token).ok_or(BatchError::BadLength { at })?;
        named = named.saturating_add(len);
        count += 1;
        at += token.len();
    }
    if count == 0 {
        return Err(BatchError::NoPackets);
    }
    if named != body.len() {
        return Err(BatchError::WrongTotal {
            named,
            present: body.len(),
        });
    }
    Ok(Pieces {
        head,
        at: 0,
        body,
        single: false,
    })
}

/// A packet length as the head writes it: 1 to [`MAX_PACKET`](crate::MAX_PACKET)
/// in decimal, no sign, no leading zero.
fn parse_length(token: &[u8]) -> Option<usize> {
    if token.is_empty() || token.len() > 5 || token[0] == b'0' {
        return None;
    }
    let mut n = 0usize;
    for &b in token {
        if !b.is_ascii_digit() {
            return None;
        }
        n = n * 10 + usize::from(b - b'0');
    }
    (n <= crate::MAX_PACKET).then_some(n)
}

/// The packets of a datagram, as byte ranges of it; see [`split`].
#[derive(Debug, Clone)]
pub struct Pieces<'a> {
    /// The head after the mark, without its line end (` 22 26`).
    head: &'a [u8],
    /// How far into `head` the lengths have been read.
    at: usize,
    /// What is left of the packets.
    body: Range<usize>,
    /// A plain packet: the whole body, once.
    single: bool,
}

impl Iterator for Pieces<'_> {
    type Item = Range<usize>;

    fn next(&mut self) -> Option<Range<usize>> {
        if self.single {
            self.single = false;
            return Some(std::mem::replace(&mut self.body, 0..0));
        }
        // `split` checked the whole head, so each step reads one length.
        let rest = self.head.get(self.at + 1..)?;
        let token = rest.split(|&b| b == b' ').next()?;
        self.at += 1 + token.len();
        // Checked by `split`.
        let len = parse_length(token)?;
        let start = self.body.start;
        self.body.start += len;
        Some(start..start + len)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn pieces(d: &[u8]) -> Result<Vec<&[u8]>, BatchError> {
        Ok(split(d)?.map(|r| &d[r]).collect())
    }

    #[test]
    fn a_plain_packet_is_one_piece() {
        assert_eq!(pieces(b"@ <a> 0\nx y 1\n").unwrap(), [b"@ <a> 0\nx y 1\n"]);
        // Whatever it holds: it is parsed, and refused, as a packet.
        assert_eq!(pieces(b"junk").unwrap(), [b"junk"]);
        assert_eq!(pieces(b"").unwrap(), [b""]);
    }

    #[test]
    fn a_body_line_that_looks_like_a_header_stays_in_its_packet() {
        // A publisher's own packet with a line `@ <hub> 99` in its body: cut
        // at headers, it would be two packets, the second on `<hub>`.
        let sneaky = b"@ <a> 0\n@ <secret> 99\nx y 1\n";
        let d = join(&[sneaky, b"@ <a> 0\n"]);
        assert_eq!(pieces(&d).unwrap(), [&sneaky[..], b"@ <a> 0\n"]);
    }

    #[test]
    fn damaged_heads_are_refused_with_where() {
        use BatchError::*;
        assert_eq!(split(b"% 8").unwrap_err(), UnendedHead);
        assert_eq!(split(b"%\n").unwrap_err(), NoPackets);
        assert_eq!(
            split(b"% 8 9\n@ <a> 0\n").unwrap_err(),
            WrongTotal {
                named: 17,
                present: 8
            }
        );
        assert_eq!(split(b"% 08\n@ <a> 0\n").unwrap_err(), BadLength { at: 2 });
        assert_eq!(split(b"% 4  4\n12345678").unwrap_err(), BadLength { at: 4 });
        assert_eq!(split(b"% -8\n").unwrap_err(), BadLength { at: 2 });
        assert_eq!(split(b"%8\n@ <a> 0\n").unwrap_err(), BadLength { at: 1 });
        assert_eq!(split(b"% 8 \n@ <a> 0\n").unwrap_err(), BadLength { at: 4 });
        assert_eq!(split(b"% 0\n").unwrap_err(), BadLength { at: 2 });
        assert_eq!(split(b"% 65508\n").unwrap_err(), BadLength { at: 2 });
        // Far more named than a datagram holds: no overflow.
        let huge = format!("%{}\n", " 65507".repeat(100_000));
        assert!(matches!(
            split(huge.as_bytes()).unwrap_err(),
            WrongTotal { .. }
        ));
        assert!(!BadLength { at: 3 }.to_string().is_empty());
    }

    proptest! {
        #[test]
        fn what_is_joined_splits_back(
            packets in proptest::collection::vec(proptest::collection::vec(any::<u8>(), 1..300), 1..40)
        ) {
            let refs: Vec<&[u8]> = packets.iter().map(Vec::as_slice).collect();
            let d = join(&refs);
            let lengths: Vec<usize> = refs.iter().map(|p| p.len()).collect();
            prop_assert_eq!(
                d.len(),
                HEAD_BASE + lengths.iter().map(|&l| head_cost(l) + l).sum::<usize>()
            );
            prop_assert_eq!(pieces(&d).unwrap(), refs);
        }

        #[test]
        fn any_bytes_split_into_ranges_inside_them_or_are_refused(
            lengths in proptest::collection::vec(1usize..30, 1..6),
            // Mostly a body of the total the head names, sometimes off by a few.
            off in proptest::sample::select(vec![0i64, 0, 0, -2, -1, 1, 3]),
            noise in "[0-9 ]{0,3}",
            fill in any::<u8>(),
        ) {
            let mut head = Vec::new();
            write_head(&lengths, &mut head);
            // Now and then a damaged head: stray digits or spaces before its end.
            if noise.len() == 3 {
                head.pop();
                head.extend_from_slice(noise.as_bytes());
                head.push(b'\n');
            }
            let head = String::from_utf8(head).unwrap();
            let total = lengths.iter().sum::<usize>() as i64 + off;
            let body = vec![fill; total.max(0) as usize];
            let d = [head.as_bytes(), &body].concat();
            if noise.len() < 3 {
                // A head as written splits exactly when the body adds up.
                prop_assert_eq!(split(&d).is_ok(), off == 0);
            }
            if let Ok(p) = split(&d) {
                let ranges: Vec<Range<usize>> = p.collect();
                prop_assert!(!ranges.is_empty());
                // Back to back, to the datagram's end.
                prop_assert_eq!(ranges[0].start, head.len());
                prop_assert_eq!(ranges.last().unwrap().end, d.len());
                prop_assert!(ranges.windows(2).all(|w| w[0].end == w[1].start));
                prop_assert!(ranges.iter().all(|r| !r.is_empty()));
            }
        }

        #[test]
        fn head_cost_is_what_the_head_takes(lengths in proptest::collection::vec(1usize..=65_507, 0..50)) {
            let mut out = Vec::new();
            write_head(&lengths, &mut out);
            prop_assert_eq!(out.len(), HEAD_BASE + lengths.iter().map(|&l| head_cost(l)).sum::<usize>());
        }
    }
}
