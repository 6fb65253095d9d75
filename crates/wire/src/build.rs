//! Writing packets: a builder as quick to use as `printf`, checked before it is sent.

use std::fmt::Write as _;

use crate::error::ParseError;
use crate::{scan, Packet, Priority};

/// Builds a packet's text line by line.
///
/// Nothing here can panic on odd names or values: [`PacketBuilder::finish`]
/// runs the parser over the result, so a packet that leaves the builder is one
/// every reader accepts.
///
/// ```
/// use colony_wire::{PacketBuilder, Packet, Priority};
/// let mut b = PacketBuilder::new(["vision_out"], Priority(0));
/// b.line("ball").field("x", 5.3).field("y", -2.5);
/// b.line("blue").field("id", 0).field("x", 15.2).group("pose", |g| {
///     g.field("xh", 1.0).field("yh", 0.0);
/// });
/// b.line("note").field("text", "kick \"off\"");
/// let bytes = b.finish().unwrap();
/// let p = Packet::parse(&bytes).unwrap();
/// assert_eq!(p.line("note").unwrap().str("text").unwrap(), "kick \"off\"");
/// ```
#[derive(Debug, Clone)]
pub struct PacketBuilder {
    text: String,
}

impl PacketBuilder {
    /// Starts a packet to `subjects` (one subject is a channel) at `priority`.
    pub fn new<S: AsRef<str>>(subjects: impl IntoIterator<Item = S>, priority: Priority) -> Self {
        let mut text = String::with_capacity(256);
        text.push('@');
        for s in subjects {
            let _ = write!(text, " <{}>", s.as_ref());
        }
        let _ = writeln!(text, " {}", priority.0);
        PacketBuilder { text }
    }

    /// Starts a new line with this label; add its fields to the value returned.
    pub fn line(&mut self, label: &str) -> LineBuilder<'_> {
        if !self.text.ends_with('\n') {
            self.text.push('\n');
        }
        self.text.push_str(label);
        LineBuilder {
            text: &mut self.text,
        }
    }

    /// Appends a line written by hand, such as `"ball x 5.3 y -2.5"`.
    pub fn raw_line(&mut self, line: &str) -> &mut Self {
        if !self.text.ends_with('\n') {
            self.text.push('\n');
        }
        self.text.push_str(line);
        self
    }

    /// The text so far; it may not be valid until [`finish`](Self::finish) says so.
    pub fn as_str(&self) -> &str {
        &self.text
    }

    /// Checks the packet and returns its bytes, ready to send.
    pub fn finish(mut self) -> Result<Vec<u8>, ParseError> {
        if !self.text.ends_with('\n') {
            self.text.push('\n');
        }
        Packet::parse(self.text.as_bytes())?;
        Ok(self.text.into_bytes())
    }
}

/// Adds fields to one line (or, through [`LineBuilder::group`], to a group).
pub struct LineBuilder<'b> {
    text: &'b mut String,
}

impl LineBuilder<'_> {
    /// Adds `name value`; numbers are written so that they read back exactly,
    /// text is quoted and escaped.
    pub fn field(&mut self, name: &str, value: impl WireValue) -> &mut Self {
        self.text.push(' ');
        self.text.push_str(name);
        self.text.push(' ');
        value.write_to(self.text);
        self
    }

    /// Adds `name token` with the token written bare, as is.
    pub fn bare(&mut self, name: &str, token: &str) -> &mut Self {
        self.text.push(' ');
        self.text.push_str(name);
        self.text.push(' ');
        self.text.push_str(token);
        self
    }

    /// Adds `name ( ... )`, the fields inside written by `fill`.
    pub fn group(&mut self, name: &str, fill: impl FnOnce(&mut LineBuilder<'_>)) -> &mut Self {
        self.text.push(' ');
        self.text.push_str(name);
        self.text.push_str(" (");
        let open = self.text.len();
        fill(&mut LineBuilder { text: self.text });
        if self.text.len() > open {
            // The inner fields were written with a leading blank each; keep `(a 1)` tidy.
            self.text.remove(open);
        }
        self.text.push(')');
        self
    }
}

/// A value the builder knows how to write.
pub trait WireValue {
    /// Appends the value as packet text.
    fn write_to(&self, out: &mut String);
}

macro_rules! wire_int {
    ($($t:ty),*) => {$(
        impl WireValue for $t {
            fn write_to(&self, out: &mut String) {
                let _ = write!(out, "{self}");
            }
        }
    )*};
}
wire_int!(i8, i16, i32, i64, u8, u16, u32, u64, usize, isize);

impl WireValue for f64 {
    fn write_to(&self, out: &mut String) {
        // `{:?}` is the shortest text that reads back to the same bits, and
        // switches to exponent form for very large or small values.
        let _ = write!(out, "{self:?}");
    }
}

impl WireValue for f32 {
    fn write_to(&self, out: &mut String) {
        let _ = write!(out, "{self:?}");
    }
}

impl WireValue for bool {
    fn write_to(&self, out: &mut String) {
        out.push_str(if *self { "true" } else { "false" });
    }
}

impl WireValue for str {
    fn write_to(&self, out: &mut String) {
        write_quoted(out, self);
    }
}

impl WireValue for String {
    fn write_to(&self, out: &mut String) {
        write_quoted(out, self);
    }
}

impl<T: WireValue + ?Sized> WireValue for &T {
    fn write_to(&self, out: &mut String) {
        (**self).write_to(out);
    }
}

/// Writes `s` as a quoted string with the format's escapes.
pub fn write_quoted(out: &mut String, s: &str) {
    out.reserve(s.len() + 2);
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            c if (c as u32) < 0x20 || c == '\u{7f}' => out.push('\u{fffd}'),
            c => out.push(c),
        }
    }
    out.push('"');
}

/// Writes `s` bare if it can stand as a token, quoted otherwise.
pub fn write_token_or_quoted(out: &mut String, s: &str) {
    if scan::is_bare_token(s) {
        out.push_str(s);
    } else {
        write_quoted(out, s);
    }
}
