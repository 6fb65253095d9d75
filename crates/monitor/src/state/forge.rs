//! Checking a packet the operator typed into the hub view, before it is published.

use colony_wire::Packet;
use serde::Serialize;

/// Checks a packet typed by the operator, as the hub will: the error names its line and column.
/// Windows line ends are made plain and a missing final line end is added.
pub fn check_forged(text: &str) -> Result<Vec<u8>, ForgeError> {
    let mut bytes = text.replace("\r\n", "\n").into_bytes();
    if !bytes.ends_with(b"\n") {
        bytes.push(b'\n');
    }
    match Packet::parse(&bytes) {
        Ok(_) => Ok(bytes),
        Err(e) => Err(ForgeError {
            line: e.line,
            column: e.column,
            message: e.to_string(),
        }),
    }
}

/// Why a forged packet was refused, and where (the page points at it).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, thiserror::Error)]
#[error("{message}")]
pub struct ForgeError {
    /// 1-based line of the packet.
    pub line: u32,
    /// 1-based column in that line.
    pub column: u32,
    /// The parser's message.
    pub message: String,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_forged_packet_is_checked_with_its_line_and_column() {
        assert_eq!(
            check_forged("@ <test> 0\nhello x 1").unwrap(),
            b"@ <test> 0\nhello x 1\n"
        );
        let e = check_forged("@ <test> 0\nhello x (y 1\n").unwrap_err();
        assert_eq!(e.line, 2);
        assert!(e.column > 1);
        assert!(!e.message.is_empty());
        assert_eq!(check_forged("").unwrap_err().line, 1);
        assert!(check_forged("@ <a b> 0\n").is_err());
        assert_eq!(
            check_forged("@ <t> 0\r\nx v 1\r\n").unwrap(),
            b"@ <t> 0\nx v 1\n"
        );
    }
}
