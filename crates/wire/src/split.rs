//! Text holding several packets one after another (a file, standard input),
//! cut into the packets.

/// Cuts `text` at each line that starts with `@` (a header), so each piece
/// is one packet's text; anything before the first header is left out.
/// The pieces are not parsed: hand each to [`Packet::parse`](crate::Packet::parse).
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

    proptest! {
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
