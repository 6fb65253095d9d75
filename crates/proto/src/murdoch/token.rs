//! Tokens: the short names agents and announcers give themselves in bids.

use std::fmt;

/// A short name for an agent or an announcer, used in bids to say who bid (never
/// to address anyone): 1 to 24 characters of `A-Z a-z 0-9 _ -`.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Token(Box<str>);

/// The most characters a [`Token`] may have, so that a negotiation subject
/// built from one stays within a subject's 64.
pub const MAX_TOKEN_LEN: usize = 24;

/// A name that cannot be a token.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("`{0}` is not a token: use 1 to {MAX_TOKEN_LEN} characters of A-Z a-z 0-9 _ -")]
pub struct TokenError(pub String);

impl Token {
    /// Checks `s`.
    pub fn new(s: &str) -> Result<Token, TokenError> {
        let ok = !s.is_empty()
            && s.len() <= MAX_TOKEN_LEN
            && s.bytes()
                .all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-');
        if ok {
            Ok(Token(s.into()))
        } else {
            Err(TokenError(s.chars().take(80).collect()))
        }
    }

    /// The token's text.
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl std::str::FromStr for Token {
    type Err = TokenError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Token::new(s)
    }
}

impl fmt::Display for Token {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_token_is_one_to_24_characters_of_its_alphabet() {
        for ok in ["r", "r2", "Robot_7-b", "x".repeat(MAX_TOKEN_LEN).as_str()] {
            assert_eq!(Token::new(ok).unwrap().as_str(), ok);
        }
        for bad in [
            "",
            "r 1",
            "r.1",
            "r:1",
            "r/1",
            "\u{e9}",
            "x".repeat(MAX_TOKEN_LEN + 1).as_str(),
        ] {
            assert!(Token::new(bad).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn a_token_error_keeps_at_most_80_characters_of_the_input() {
        let long = "é".repeat(200);
        let TokenError(kept) = Token::new(&long).unwrap_err();
        assert_eq!(kept.chars().count(), 80);
        let e = Token::new("a b").unwrap_err().to_string();
        assert!(e.contains("`a b` is not a token"), "{e}");
    }

    #[test]
    fn tokens_parse_and_print_as_their_text() {
        let t: Token = "r2".parse().unwrap();
        assert_eq!(t.to_string(), "r2");
        assert!("r 2".parse::<Token>().is_err());
    }

    proptest::proptest! {
        #[test]
        fn any_text_is_a_token_exactly_when_it_fits_the_alphabet(text in "\\PC{0,30}") {
            let fits = !text.is_empty()
                && text.len() <= MAX_TOKEN_LEN
                && text.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-');
            match Token::new(&text) {
                Ok(t) => {
                    proptest::prop_assert!(fits);
                    proptest::prop_assert_eq!(t.to_string(), text);
                }
                Err(TokenError(kept)) => {
                    proptest::prop_assert!(!fits);
                    proptest::prop_assert!(text.starts_with(&kept));
                }
            }
        }
    }
}
