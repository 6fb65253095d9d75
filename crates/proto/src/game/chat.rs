//! `game.chat.TEAM`: a chat line between the players of one team. Only the team's players
//! subscribe to its channel (the game page's server passes a team's lines only to the pages
//! playing that team).
//!
//! ```text
//! @ <game.chat.red> 0
//! chat from ada text "bravo, hold the bridge"
//! ```

use colony_wire::{Packet, PacketBuilder, ParseError, Priority};

use super::chat_channel;
use crate::fields::{bad, plain_name, text_or_empty};
use crate::table::{line, text, MessageTable};
use crate::DecodeError;

/// The longest chat text, characters: a line to read at a glance, not a document.
pub const MAX_CHAT: usize = 200;

/// What a chat packet holds, on every `game.chat.TEAM`.
pub const TABLE: MessageTable = MessageTable {
    channel: "game.chat.",
    lines: &[line("chat", &[text("from"), text("text").optional()])],
};

/// One line of a team's chat.
#[derive(Debug, Clone, PartialEq)]
pub struct ChatLine {
    /// The team it is for (from the channel).
    pub team: String,
    /// Who wrote it: a player's name.
    pub from: String,
    /// What they wrote.
    pub text: String,
}

impl ChatLine {
    /// The packet, on the team's chat channel.
    pub fn encode(&self) -> Result<Vec<u8>, ParseError> {
        let mut p = PacketBuilder::new([chat_channel(&self.team)], Priority(0));
        p.line("chat")
            .bare("from", &self.from)
            .field("text", self.text.as_str());
        p.finish()
    }

    /// Reads the chat lines of a packet that came on `team`'s chat channel.
    pub fn decode(team: &str, packet: &Packet<'_>) -> Result<Vec<ChatLine>, DecodeError> {
        packet
            .lines_labelled("chat")
            .map(|l| {
                let said = text_or_empty(&l, "text")?;
                if said.chars().count() > MAX_CHAT || said.chars().any(char::is_control) {
                    return Err(bad(
                        &l,
                        format!("a chat text is at most {MAX_CHAT} printable characters"),
                    ));
                }
                Ok(ChatLine {
                    team: team.to_string(),
                    from: plain_name(&l, "from")?,
                    text: said,
                })
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_chat_line_is_read_as_sent_and_a_long_one_refused() {
        let c = ChatLine {
            team: "red".into(),
            from: "ada".into(),
            text: "bravo, \"hold\" the bridge".into(),
        };
        let bytes = c.encode().unwrap();
        let p = Packet::parse(&bytes).unwrap();
        assert_eq!(ChatLine::decode("red", &p).unwrap(), vec![c]);
        crate::table::check::codec(&TABLE, std::slice::from_ref(&bytes), |p| {
            ChatLine::decode("red", p).is_ok()
        });
        // (A control character never arrives: the packet writer replaces it, the parser refuses it.)
        let long = ChatLine {
            team: "red".into(),
            from: "ada".into(),
            text: "x".repeat(MAX_CHAT + 1),
        };
        let bytes = long.encode().unwrap();
        let p = Packet::parse(&bytes).unwrap();
        assert!(ChatLine::decode("red", &p).is_err());
    }
}
