//! The tokenizer shared by validation and iteration.
//!
//! A packet is validated once, whole, by [`validate`]; the iterators in
//! [`crate::packet`] then scan the same bytes again lazily and can trust them.

use crate::error::{ErrorKind, ParseError};
use crate::{MAX_DEPTH, MAX_PACKET, MAX_SUBJECTS, MAX_SUBJECT_LEN};

/// Byte classes, one table lookup per byte on the hot path.
const BARE: u8 = 1; // may stand in a bare token
const QUOTE_STOP: u8 = 2; // ends the fast run inside a quoted string
const CLASS: [u8; 256] = {
    let mut t = [0u8; 256];
    let mut b = 0;
    while b < 256 {
        let c = b as u8;
        let control = c < 0x20 || c == 0x7f;
        let delim = matches!(c, b' ' | b'"' | b'(' | b')');
        if !control && !delim {
            t[b] |= BARE;
        }
        // A raw tab may stand inside a string (it is no error anywhere, and
        // `printf '... "a\tb"'` sends one); every other control character stops.
        if (control && c != b'\t') || c == b'"' || c == b'\\' {
            t[b] |= QUOTE_STOP;
        }
        b += 1;
    }
    t
};

#[inline]
pub(crate) fn is_bare_byte(b: u8) -> bool {
    CLASS[b as usize] & BARE != 0
}

/// Whether `s` can be written as a bare token (no quoting needed).
pub(crate) fn is_bare_token(s: &str) -> bool {
    !s.is_empty() && s.bytes().all(is_bare_byte)
}

pub(crate) fn is_subject_byte(b: u8) -> bool {
    b.is_ascii_alphanumeric() || matches!(b, b'_' | b'-' | b'.' | b':' | b'/')
}

/// Whether `s` is a valid subject name (without the angle brackets).
pub(crate) fn is_subject(s: &str) -> bool {
    !s.is_empty() && s.len() <= MAX_SUBJECT_LEN && s.bytes().all(is_subject_byte)
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Tok<'a> {
    Bare(&'a str),
    /// The raw text between the quotes, escapes not yet resolved.
    Quoted(&'a str),
    Open,
    Close,
    /// End of line or of packet.
    Eol,
}

/// A cursor over the packet text that knows its line and column.
#[derive(Clone)]
pub(crate) struct Scanner<'a> {
    src: &'a str,
    pub(crate) pos: usize,
    pub(crate) line: u32,
    pub(crate) line_start: usize,
    /// The line just ended, so an error found at its end is reported on it.
    prev: (u32, usize),
}

impl<'a> Scanner<'a> {
    pub(crate) fn new(src: &'a str) -> Self {
        Scanner::at(src, 0, 1, 0)
    }

    pub(crate) fn at(src: &'a str, pos: usize, line: u32, line_start: usize) -> Self {
        Scanner {
            src,
            pos,
            line,
            line_start,
            prev: (line, line_start),
        }
    }

    pub(crate) fn source(&self) -> &'a str {
        self.src
    }

    pub(crate) fn at_end(&self) -> bool {
        self.pos >= self.src.len()
    }

    fn bytes(&self) -> &'a [u8] {
        self.src.as_bytes()
    }

    pub(crate) fn error_at(&self, pos: usize, kind: ErrorKind) -> ParseError {
        let (line, start) = if pos < self.line_start {
            self.prev
        } else {
            (self.line, self.line_start)
        };
        ParseError {
            kind,
            line,
            column: (pos.saturating_sub(start) + 1) as u32,
        }
    }

    fn char_at(&self, pos: usize) -> char {
        self.src
            .get(pos..)
            .and_then(|rest| rest.chars().next())
            .unwrap_or('\u{fffd}')
    }

    fn new_line(&mut self, next_start: usize) {
        self.prev = (self.line, self.line_start);
        self.pos = next_start;
        self.line += 1;
        self.line_start = next_start;
    }

    pub(crate) fn skip_ws(&mut self) {
        let b = self.bytes();
        while self.pos < b.len() && (b[self.pos] == b' ' || b[self.pos] == b'\t') {
            self.pos += 1;
        }
    }

    /// Consumes the line end (`\n`, `\r\n`, or the end of the packet) if it is next.
    fn take_eol(&mut self) -> Result<bool, ParseError> {
        let b = self.bytes();
        match b.get(self.pos) {
            None => Ok(true),
            Some(b'\n') => {
                self.new_line(self.pos + 1);
                Ok(true)
            }
            Some(b'\r') if b.get(self.pos + 1) == Some(&b'\n') => {
                self.new_line(self.pos + 2);
                Ok(true)
            }
            Some(&c) if c < 0x20 || c == 0x7f => {
                Err(self.error_at(self.pos, ErrorKind::ControlChar(c)))
            }
            Some(_) => Ok(false),
        }
    }

    /// Next token after any blanks; returns it with the byte offset it starts at.
    pub(crate) fn next(&mut self) -> Result<(Tok<'a>, usize), ParseError> {
        self.skip_ws();
        let start = self.pos;
        if self.take_eol()? {
            return Ok((Tok::Eol, start));
        }
        let b = self.bytes();
        match b[start] {
            b'(' => {
                self.pos += 1;
                Ok((Tok::Open, start))
            }
            b')' => {
                self.pos += 1;
                Ok((Tok::Close, start))
            }
            b'"' => self.quoted(start),
            _ => {
                let mut p = start;
                while p < b.len() && is_bare_byte(b[p]) {
                    p += 1;
                }
                self.pos = p;
                Ok((Tok::Bare(&self.src[start..p]), start))
            }
        }
    }

    fn quoted(&mut self, start: usize) -> Result<(Tok<'a>, usize), ParseError> {
        let b = self.bytes();
        let mut p = start + 1;
        loop {
            while p < b.len() && CLASS[b[p] as usize] & QUOTE_STOP == 0 {
                p += 1;
            }
            match b.get(p) {
                None | Some(b'\n') | Some(b'\r') => {
                    return Err(self.error_at(start, ErrorKind::UnterminatedString))
                }
                Some(b'"') => {
                    self.pos = p + 1;
                    return Ok((Tok::Quoted(&self.src[start + 1..p]), start));
                }
                Some(b'\\') => match b.get(p + 1) {
                    Some(b'"' | b'\\' | b'n' | b'r' | b't') => p += 2,
                    None | Some(b'\n') | Some(b'\r') => {
                        return Err(self.error_at(start, ErrorKind::UnterminatedString))
                    }
                    Some(_) => {
                        return Err(self.error_at(p, ErrorKind::BadEscape(self.char_at(p + 1))))
                    }
                },
                Some(&c) => return Err(self.error_at(p, ErrorKind::ControlChar(c))),
            }
        }
    }

    /// Skips a group whose `(` has just been consumed, leaving the cursor after its `)`.
    pub(crate) fn skip_group(&mut self) -> Result<(), ParseError> {
        let mut depth = 1usize;
        loop {
            match self.next()? {
                (Tok::Open, _) => depth += 1,
                (Tok::Close, _) => {
                    depth -= 1;
                    if depth == 0 {
                        return Ok(());
                    }
                }
                (Tok::Eol, p) => return Err(self.error_at(p, ErrorKind::UnclosedGroup)),
                _ => {}
            }
        }
    }

    /// Advances to the start of the next line (used to skip a whole line quickly).
    pub(crate) fn skip_line(&mut self) {
        let b = self.bytes();
        match b[self.pos.min(b.len())..].iter().position(|&c| c == b'\n') {
            Some(off) => self.new_line(self.pos + off + 1),
            None => self.pos = b.len(),
        }
    }
}

/// Where the parts of a valid packet lie, found by [`validate`].
#[derive(Debug, Clone, Copy)]
pub(crate) struct Layout {
    /// Byte range of the subjects in the header, `<a> <b>`.
    pub(crate) subjects: (usize, usize),
    pub(crate) subject_count: u8,
    pub(crate) priority: i32,
    /// Byte offset where the body (the second line) starts.
    pub(crate) body: usize,
}

/// Checks the whole packet and finds its header; every later scan can trust the text.
pub(crate) fn validate(bytes: &[u8]) -> Result<(&str, Layout), ParseError> {
    let at = |kind| ParseError {
        kind,
        line: 1,
        column: 1,
    };
    if bytes.len() > MAX_PACKET {
        return Err(at(ErrorKind::TooLarge { len: bytes.len() }));
    }
    if bytes.is_empty() {
        return Err(at(ErrorKind::Empty));
    }
    let src = std::str::from_utf8(bytes).map_err(|e| {
        let good = &bytes[..e.valid_up_to()];
        let line = good.iter().filter(|&&b| b == b'\n').count() as u32 + 1;
        let line_start = good.iter().rposition(|&b| b == b'\n').map_or(0, |p| p + 1);
        ParseError {
            kind: ErrorKind::NotUtf8,
            line,
            column: (good.len() - line_start + 1) as u32,
        }
    })?;
    let mut s = Scanner::new(src);
    let layout = header(&mut s)?;
    body(&mut s)?;
    Ok((src, layout))
}

fn header(s: &mut Scanner<'_>) -> Result<Layout, ParseError> {
    let b = s.src.as_bytes();
    if b[0] != b'@' {
        return Err(s.error_at(0, ErrorKind::BadHeader("`@` at the start of the packet")));
    }
    s.pos = 1;
    if !matches!(b.get(1), Some(b' ' | b'\t')) {
        return Err(s.error_at(1, ErrorKind::BadHeader("a blank after `@`")));
    }
    s.skip_ws();
    let first = s.pos;
    let mut last_end = first;
    let mut names: [&str; MAX_SUBJECTS] = [""; MAX_SUBJECTS];
    let mut count = 0usize;
    while b.get(s.pos) == Some(&b'<') {
        let open = s.pos;
        let close = b[open..]
            .iter()
            .position(|&c| c == b'>' || c == b'\n')
            .map(|off| open + off)
            .filter(|&p| b[p] == b'>')
            .ok_or_else(|| s.error_at(open, ErrorKind::BadHeader("`>` to close the subject")))?;
        let name = &s.src[open + 1..close];
        if !is_subject(name) {
            return Err(s.error_at(open, ErrorKind::BadSubject(name.to_owned())));
        }
        if names[..count].contains(&name) {
            return Err(s.error_at(open, ErrorKind::DuplicateSubject(name.to_owned())));
        }
        if count == MAX_SUBJECTS {
            return Err(s.error_at(open, ErrorKind::BadHeader("at most 16 subjects")));
        }
        names[count] = name;
        count += 1;
        s.pos = close + 1;
        last_end = s.pos;
        match b.get(s.pos) {
            Some(b' ' | b'\t') => {}
            None | Some(b'\r' | b'\n') => {
                return Err(s.error_at(
                    s.pos,
                    ErrorKind::BadHeader("an integer priority after the subjects"),
                ))
            }
            Some(_) => {
                return Err(s.error_at(s.pos, ErrorKind::BadHeader("a blank after the subject")))
            }
        }
        s.skip_ws();
    }
    if count == 0 {
        return Err(s.error_at(s.pos, ErrorKind::BadHeader("a `<subject>`")));
    }
    let prio_at = s.pos;
    let priority = match s.next()? {
        (Tok::Bare(text), _) => text
            .parse::<i32>()
            .map_err(|_| s.error_at(prio_at, ErrorKind::BadPriority(text.to_owned())))?,
        _ => return Err(s.error_at(prio_at, ErrorKind::BadHeader("an integer priority"))),
    };
    let end_at = s.pos;
    match s.next()? {
        (Tok::Eol, _) => {}
        _ => {
            return Err(s.error_at(
                end_at,
                ErrorKind::BadHeader("the end of the header after the priority"),
            ))
        }
    }
    Ok(Layout {
        subjects: (first, last_end),
        subject_count: count as u8,
        priority,
        body: s.pos,
    })
}

/// Names seen in each open line or group, to reject duplicates.
///
/// A frame with few names is searched linearly (the common case, and the
/// fastest); past [`LINEAR`] names it gets a hash set so a hostile line with
/// thousands of fields still costs linear time.
struct NameFrames<'a> {
    names: Vec<&'a str>,
    frames: Vec<(usize, Option<std::collections::HashSet<&'a str>>)>,
}

const LINEAR: usize = 16;

impl<'a> NameFrames<'a> {
    fn reset(&mut self) {
        self.names.clear();
        self.frames.clear();
        self.frames.push((0, None));
    }

    /// Records `name` in the innermost frame; false if it was there already.
    fn insert(&mut self, name: &'a str) -> bool {
        let (start, set) = self.frames.last_mut().expect("a line frame is always open");
        if let Some(set) = set {
            return set.insert(name);
        }
        let frame = &self.names[*start..];
        if frame.contains(&name) {
            return false;
        }
        if frame.len() >= LINEAR {
            let mut all: std::collections::HashSet<&str> = frame.iter().copied().collect();
            all.insert(name);
            *set = Some(all);
            return true;
        }
        self.names.push(name);
        true
    }

    fn open(&mut self) {
        self.frames.push((self.names.len(), None));
    }

    fn close(&mut self) {
        if let Some((start, _)) = self.frames.pop() {
            self.names.truncate(start);
        }
    }

    fn depth(&self) -> usize {
        self.frames.len() - 1
    }
}

fn body(s: &mut Scanner<'_>) -> Result<(), ParseError> {
    let mut frames = NameFrames {
        names: Vec::new(),
        frames: Vec::new(),
    };
    while !s.at_end() {
        frames.reset();
        match s.next()? {
            (Tok::Eol, _) => continue,
            (Tok::Bare(_), _) => {}
            (_, p) => return Err(s.error_at(p, ErrorKind::ExpectedLabel(s.char_at(p)))),
        }
        loop {
            let (tok, p) = s.next()?;
            let name = match tok {
                Tok::Eol if frames.depth() > 0 => {
                    return Err(s.error_at(p, ErrorKind::UnclosedGroup))
                }
                Tok::Eol => break,
                Tok::Close if frames.depth() == 0 => {
                    return Err(s.error_at(p, ErrorKind::UnmatchedClose))
                }
                Tok::Close => {
                    frames.close();
                    continue;
                }
                Tok::Bare(name) => name,
                Tok::Quoted(_) | Tok::Open => {
                    return Err(s.error_at(p, ErrorKind::ExpectedName(s.char_at(p))))
                }
            };
            if !frames.insert(name) {
                return Err(s.error_at(
                    p,
                    ErrorKind::DuplicateName {
                        name: name.to_owned(),
                    },
                ));
            }
            let (value, vp) = s.next()?;
            match value {
                Tok::Bare(_) | Tok::Quoted(_) => {}
                Tok::Open if frames.depth() >= MAX_DEPTH => {
                    return Err(s.error_at(vp, ErrorKind::TooDeep))
                }
                Tok::Open => frames.open(),
                Tok::Eol | Tok::Close => {
                    return Err(s.error_at(
                        p,
                        ErrorKind::MissingValue {
                            name: name.to_owned(),
                        },
                    ))
                }
            }
        }
    }
    Ok(())
}
