//! Text holding several packets one after another (standard input, what
//! `colony sub` and `colony log` print), cut into the packets.
//!
//! A body line may start with `@` (a bare label), so a header line cannot
//! mark where a packet starts: `@ <radio> 10` in the body of a packet on
//! `chat` would become a packet of its own, on `radio` at priority 10. Text
//! from anyone else goes in blocks instead: one packet per block, blocks
//! apart by a blank line, which no packet in canonical form holds (each of
//! its lines has a label), and `#` notes before a block's header.
//!
//! ```text
//! # +0.100000 s from 127.0.0.1:5
//! @ <chat> 0
//! @ <radio> 10
//!
//! @ <chat> 0
//! say text "hi"
//! ```

use std::fmt;

use crate::packet::Packet;
use crate::terminal::{terminal_line, terminal_text};

/// Cuts `text` at each line that starts with `@` (a header), so each piece
/// is one packet's text; anything before the first header is left out.
/// The pieces are not parsed: hand each to [`Packet::parse`](crate::Packet::parse).
///
/// Only for text known to hold no body line that starts with `@` (a fixture of
/// colony's own packets): a body line can start a packet here. Text from a pipe
/// or a person goes through [`split_blocks`].
///
/// ```
/// let text = "@ <a> 0\nx y 1\n@ <b> 1\nz w 2\n";
/// assert_eq!(colony_wire::split_packets(text), ["@ <a> 0\nx y 1\n", "@ <b> 1\nz w 2\n"]);
/// ```
pub fn split_packets(text: &str) -> Vec<&str> {
    let mut starts: Vec<usize> = Vec::new();
    let mut offset = 0;
    for line in text.split_inclusive('\n') {
        if line.starts_with('@') {
            starts.push(offset);
        }
        offset += line.len();
    }
    starts
        .iter()
        .enumerate()
        .map(|(i, &s)| &text[s..starts.get(i + 1).copied().unwrap_or(text.len())])
        .collect()
}

/// Whether a line holds nothing but blanks: only ASCII ones count, so that a
/// label of Unicode spaces never ends a block.
fn is_blank(line: &str) -> bool {
    line.bytes()
        .all(|b| matches!(b, b' ' | b'\t' | b'\r' | b'\n'))
}

fn is_note(line: &str) -> bool {
    line.starts_with('#')
}

/// Whether `text` holds packets in blocks ([`split_blocks`]) rather than the
/// lines of one packet's body: its first line that is neither blank nor a
/// `#` note starts with `@`.
pub fn starts_with_packet(text: &str) -> bool {
    text.split_inclusive('\n')
        .find(|l| !is_blank(l) && !is_note(l))
        .is_some_and(|l| l.starts_with('@'))
}

/// One packet's text in text cut by [`split_blocks`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Block<'a> {
    /// The 1-based line of the whole text that the packet's header is on.
    pub line: usize,
    /// The packet's text, from its header to the end of its block. Not parsed:
    /// hand it to [`Packet::parse`].
    pub text: &'a str,
}

/// A block of text whose first line (after any `#` notes) is no header.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BlockError {
    /// The 1-based line where the block's text starts.
    pub line: usize,
}

impl fmt::Display for BlockError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "line {}: each packet starts with its header (`@ <subject> priority`), after a blank line and any `#` notes; a blank line ends a packet",
            self.line
        )
    }
}

impl std::error::Error for BlockError {}

/// Cuts `text` into packets, one per block of lines between blank lines: a
/// block's `#` notes are left out, the rest, from its header on, is one
/// packet, however many of its lines start with `@`. A block of notes alone
/// is no packet; a block that does not start with a header is refused whole
/// (nothing is returned), with its line.
///
/// ```
/// use colony_wire::split_blocks;
/// let text = "# a note\n@ <a> 0\n@ <b> 10\n\n@ <c> 1\nz w 2\n";
/// let texts: Vec<&str> = split_blocks(text).unwrap().iter().map(|b| b.text).collect();
/// assert_eq!(texts, ["@ <a> 0\n@ <b> 10\n", "@ <c> 1\nz w 2\n"]);
/// assert_eq!(split_blocks("@ <a> 0\n\nx y 1\n").unwrap_err().line, 3);
/// ```
pub fn split_blocks(text: &str) -> Result<Vec<Block<'_>>, BlockError> {
    let mut blocks = Vec::new();
    // Where the open block's packet starts (offset, line), once its header is seen.
    let mut packet: Option<(usize, usize)> = None;
    let mut offset = 0;
    for (i, line) in text.split_inclusive('\n').enumerate() {
        let number = i + 1;
        if is_blank(line) {
            if let Some((start, at)) = packet.take() {
                blocks.push(Block {
                    line: at,
                    text: &text[start..offset],
                });
            }
        } else if packet.is_none() {
            if line.starts_with('@') {
                packet = Some((offset, number));
            } else if !is_note(line) {
                return Err(BlockError { line: number });
            }
        }
        offset += line.len();
    }
    if let Some((start, at)) = packet {
        blocks.push(Block {
            line: at,
            text: &text[start..],
        });
    }
    Ok(blocks)
}

/// Writes packets as [`split_blocks`] reads them back: a blank line between
/// blocks, each block its notes, then one packet in canonical form.
#[derive(Debug, Default)]
pub struct BlockWriter {
    started: bool,
}

impl BlockWriter {
    /// A writer whose first block needs no blank line before it.
    pub fn new() -> BlockWriter {
        BlockWriter::default()
    }

    /// The next block: each note on a `#` line of its own (escaped by
    /// [`terminal_line`], so a note from the network can neither end the block
    /// nor act on a terminal), then the packet, if there is one, in canonical
    /// form, through [`terminal_text`] when `escaped`.
    ///
    /// ```
    /// use colony_wire::{split_blocks, BlockWriter, Packet};
    /// let p = Packet::parse(b"@ <chat> 0\n@ <radio> 10\n").unwrap();
    /// let mut w = BlockWriter::new();
    /// let text = [w.block(&["from a"], Some(&p), false), w.block(&[], Some(&p), false)].concat();
    /// assert_eq!(text, "# from a\n@ <chat> 0\n@ <radio> 10\n\n@ <chat> 0\n@ <radio> 10\n");
    /// assert_eq!(split_blocks(&text).unwrap().len(), 2);
    /// ```
    pub fn block(&mut self, notes: &[&str], packet: Option<&Packet<'_>>, escaped: bool) -> String {
        let mut out = String::new();
        if std::mem::replace(&mut self.started, true) {
            out.push('\n');
        }
        for note in notes {
            out.push_str("# ");
            out.push_str(&terminal_line(note));
            out.push('\n');
        }
        if let Some(p) = packet {
            let text = p.to_string();
            if escaped {
                out.push_str(&terminal_text(&text));
            } else {
                out.push_str(&text);
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn packets_split_at_headers() {
        let text = "@ <a> 0\nx y 1\n@ <b> 1\nz w 2\n";
        assert_eq!(
            split_packets(text),
            ["@ <a> 0\nx y 1\n", "@ <b> 1\nz w 2\n"]
        );
    }

    #[test]
    fn text_before_the_first_header_is_left_out() {
        assert_eq!(split_packets("junk\n@ <a> 0\n"), ["@ <a> 0\n"]);
        assert!(split_packets("no header\n").is_empty());
    }

    #[test]
    fn a_body_line_that_looks_like_a_header_never_starts_a_packet() {
        let text = "@ <chat> 0\n@ <radio> 10\ncmd id 3\n\n# note\n@ <b> 1\n#x y 1\n";
        assert_eq!(
            split_blocks(text).unwrap(),
            [
                Block {
                    line: 1,
                    text: "@ <chat> 0\n@ <radio> 10\ncmd id 3\n"
                },
                Block {
                    line: 6,
                    text: "@ <b> 1\n#x y 1\n"
                }
            ]
        );
    }

    #[test]
    fn blocks_of_notes_alone_are_no_packets_and_a_headless_block_is_refused() {
        assert_eq!(split_blocks("# a\n\n\n# b\n").unwrap(), []);
        assert_eq!(split_blocks("").unwrap(), []);
        assert_eq!(
            split_blocks("@ <a> 0\nx y 1\n \t\r\n# n\nz w 2\n")
                .unwrap_err()
                .line,
            5
        );
        // A label of Unicode spaces is no blank line.
        assert_eq!(
            split_blocks("@ <a> 0\n\u{a0}\n@ <b> 0\n").unwrap()[0].text,
            "@ <a> 0\n\u{a0}\n@ <b> 0\n"
        );
        assert!(!BlockError { line: 2 }.to_string().is_empty());
    }

    #[test]
    fn text_holds_packets_when_its_first_line_past_notes_is_a_header() {
        assert!(starts_with_packet("\n# note\n@ <a> 0\n"));
        assert!(!starts_with_packet("cmd id 3\n@ <a> 0\n"));
        assert!(!starts_with_packet("# only a note\n"));
        assert!(!starts_with_packet(""));
    }

    /// A valid packet's text from pieces that look like headers, notes and blanks.
    fn packet_text() -> impl Strategy<Value = String> {
        let label = prop_oneof![
            Just("@".to_string()),
            Just("#".to_string()),
            Just("%".to_string()),
            "[a-z@#%\u{a0}\u{9b}\u{202e}]{1,4}",
        ];
        let value = prop_oneof!["[a-z0-9<>@#]{1,4}", "\"[a-z @#\t\u{85}]{0,4}\"",];
        let line = (
            label,
            proptest::collection::vec(("[a-z]{1,3}", value), 0..3),
        )
            .prop_map(|(label, fields)| {
                let mut seen = std::collections::HashSet::new();
                let mut l = label;
                for (n, v) in fields {
                    if seen.insert(n.clone()) {
                        l.push_str(&format!(" {n} {v}"));
                    }
                }
                l
            });
        (
            proptest::collection::vec("[a-z]{1,5}", 1..3),
            -20i32..20,
            proptest::collection::vec(line, 0..6),
            proptest::sample::select(vec!["\n", "\r\n", "\n\n", "  \n"]),
        )
            .prop_map(|(subjects, priority, lines, end)| {
                let mut subjects = subjects;
                subjects.sort();
                subjects.dedup();
                let mut t = String::from("@");
                for s in &subjects {
                    t.push_str(&format!(" <{s}>"));
                }
                t.push_str(&format!(" {priority}{end}"));
                for l in lines {
                    t.push_str(&format!("{l}{end}"));
                }
                t
            })
    }

    proptest! {
        #[test]
        fn packets_written_in_blocks_read_back_as_they_were(
            texts in proptest::collection::vec(packet_text(), 0..8),
            notes in proptest::collection::vec("[ -~\n\u{85}]{0,12}", 0..3),
            escaped in any::<bool>(),
        ) {
            let packets: Vec<Packet<'_>> = texts.iter().map(|t| Packet::parse(t.as_bytes()).unwrap()).collect();
            let notes: Vec<&str> = notes.iter().map(String::as_str).collect();
            let mut w = BlockWriter::new();
            let text: String = packets.iter().map(|p| w.block(&notes, Some(p), escaped)).collect();
            let blocks = split_blocks(&text).unwrap();
            prop_assert_eq!(blocks.len(), packets.len());
            for (b, p) in blocks.iter().zip(&packets) {
                if escaped {
                    // Escaped text is for people: an escape inside quotes is no packet's.
                    let text = p.to_string();
                    prop_assert_eq!(b.text, terminal_text(&text));
                } else {
                    prop_assert_eq!(b.text, p.to_string());
                }
            }
        }

        #[test]
        fn any_text_splits_into_pieces_of_it_that_start_with_a_header_or_is_refused(
            lines in proptest::collection::vec("(@ |# |%|)[a-z@# ]{0,6}\r?", 0..16)
        ) {
            let text: String = lines.iter().map(|l| format!("{l}\n")).collect();
            if let Ok(blocks) = split_blocks(&text) {
                for b in &blocks {
                    prop_assert!(b.text.starts_with('@'));
                    prop_assert!(!b.text.split_inclusive('\n').any(is_blank));
                    prop_assert!(text.contains(b.text));
                    prop_assert!(text.split_inclusive('\n').nth(b.line - 1).unwrap().starts_with('@'));
                }
                // Every header that opens a block is some block's first line, and no other.
                let opening = text
                    .split_inclusive('\n')
                    .scan(true, |open, l| {
                        let starts = *open && l.starts_with('@');
                        if is_blank(l) { *open = true } else if !is_note(l) { *open = false }
                        Some(starts)
                    })
                    .filter(|&s| s)
                    .count();
                prop_assert_eq!(blocks.len(), opening);
            }
        }

        #[test]
        fn the_pieces_are_the_text_from_the_first_header_on(
            lines in proptest::collection::vec("(@ )?[a-z ]{0,8}", 1..12)
        ) {
            let text: String = lines.iter().map(|l| format!("{l}\n")).collect();
            let pieces = split_packets(&text);
            let from = text.split_inclusive('\n').position(|l| l.starts_with('@'));
            let tail: String = match from {
                Some(i) => text.split_inclusive('\n').skip(i).collect(),
                None => String::new(),
            };
            prop_assert_eq!(pieces.concat(), tail);
            prop_assert!(pieces.iter().all(|p| p.starts_with('@')));
        }
    }
}
