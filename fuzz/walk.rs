//! The walk over one datagram, shared by the fuzz targets
//! (`fuzz/fuzz_targets/parse_packet.rs`, and `split_batch.rs` for its batch
//! part) and the plain regression tests in `crates/wire/tests/` (which
//! include this file with `#[path]`).
//!
//! It parses the bytes and then reads everything a program could read: the
//! header, every line, every field, every nested group, every typed getter,
//! `Display`, the control requests and the hub's replies. Beyond not
//! panicking, it checks that the parts agree; a failed check is a finding.

use colony_wire::{
    ControlError, ErrorKind, Field, FieldError, FieldErrorKind, Group, Line, Packet, ParseError,
    Reply, Request, StatusReport, Subject, Value, MAX_DEPTH, MAX_PACKET, MAX_SUBJECTS,
};

/// Getters are checked on this many fields of each line or group; looking a
/// field up by name is a scan, so checking every field of a hostile 15,000-field
/// line would be quadratic.
const GETTER_FIELDS: usize = 16;
/// `Packet::line` is checked for this many lines, for the same reason.
const LOOKUP_LINES: usize = 16;

/// Parses `data` and walks whatever parses; returns the parse result so a
/// caller can check it was accepted or rejected as expected.
pub fn walk(data: &[u8]) -> Result<(), ParseError> {
    walk_auth(data);
    walk_batch(data);
    let packet = match Packet::parse(data) {
        Ok(p) => p,
        Err(e) => {
            check_error(data, &e);
            return Err(e);
        }
    };
    walk_packet(&packet);
    Ok(())
}

/// The hub checks a packet's `auth` line before it parses the packet: that
/// must not panic on any bytes, and what it strips must be a prefix.
fn walk_auth(data: &[u8]) {
    let key = colony_wire::auth::Key::new(b"a key for the fuzzer, long enough").unwrap();
    if let Some(body) = colony_wire::auth::strip_auth(data) {
        assert!(data.starts_with(body));
    }
    let _ = colony_wire::auth::has_auth_label(data);
    if let Ok(signed) = key.verify(data) {
        assert!(data.starts_with(signed.body));
    }
}

/// A subscriber cuts every datagram from the hub into its packets before
/// it parses them (`colony_wire::batch::split`): that must not panic on any
/// bytes, the pieces must lie back to back inside the datagram up to its
/// end, and joining them again must give the datagram back.
pub fn walk_batch(data: &[u8]) {
    use colony_wire::batch;
    let Ok(pieces) = batch::split(data) else {
        assert_eq!(data.first(), Some(&batch::BATCH_MARK));
        return;
    };
    let ranges: Vec<std::ops::Range<usize>> = pieces.collect();
    assert!(!ranges.is_empty());
    assert_eq!(ranges.last().unwrap().end, data.len());
    assert!(ranges.windows(2).all(|w| w[0].end == w[1].start));
    if data.first() == Some(&batch::BATCH_MARK) {
        let parts: Vec<&[u8]> = ranges.iter().map(|r| &data[r.clone()]).collect();
        // The head is written one way only, so the bytes come back the same.
        assert_eq!(batch::join(&parts), data);
        for part in parts {
            let _ = walk_packet_bytes(part);
        }
    } else {
        assert_eq!((ranges.len(), ranges[0].clone()), (1, 0..data.len()));
    }
}

/// Parses one packet cut from a batch and walks it.
fn walk_packet_bytes(data: &[u8]) -> Result<(), ParseError> {
    let packet = Packet::parse(data)?;
    walk_packet(&packet);
    Ok(())
}

fn check_error(data: &[u8], e: &ParseError) {
    assert!(!e.to_string().is_empty());
    assert!(e.line >= 1 && e.column >= 1, "{e:?}");
    if matches!(e.kind, ErrorKind::TooLarge { .. } | ErrorKind::Empty) {
        assert_eq!((e.line, e.column), (1, 1), "{e:?}");
        return;
    }
    assert!(data.len() <= MAX_PACKET && !data.is_empty(), "{e:?}");
    let line = data
        .split(|&b| b == b'\n')
        .nth(e.line as usize - 1)
        .unwrap_or_else(|| panic!("{e:?} names a line the packet does not have"));
    assert!(
        e.column as usize <= line.len() + 1,
        "{e:?} names a column past the end of its line ({} bytes)",
        line.len()
    );
}

/// Where each line of the text starts, to turn a (line, column) back into an offset.
struct Text<'a> {
    src: &'a str,
    starts: Vec<usize>,
}

impl Text<'_> {
    fn offset(&self, line: u32, column: u32) -> usize {
        self.starts[line as usize - 1] + column as usize - 1
    }
}

fn walk_packet(p: &Packet<'_>) {
    let src = p.as_str();
    let text = Text {
        src,
        starts: std::iter::once(0)
            .chain(src.match_indices('\n').map(|(i, _)| i + 1))
            .collect(),
    };

    // Header.
    let subjects: Vec<&str> = p.subjects().collect();
    assert_eq!(subjects.len(), p.subject_count());
    assert!((1..=MAX_SUBJECTS).contains(&subjects.len()));
    for s in &subjects {
        assert!(p.has_subject(s));
        assert_eq!(
            Subject::new(s).expect("header subjects are valid").as_str(),
            *s
        );
        assert!(p.subjects_text().contains(&format!("<{s}>")));
    }
    let _ = p.priority();
    let _ = format!("{p:?}");

    // Body.
    let mut last = 1;
    for (i, line) in p.lines().enumerate() {
        assert!(line.number() > last, "line numbers increase");
        last = line.number();
        assert!(!line.label().is_empty());
        let start = &src[text.offset(line.number(), 1)..];
        assert!(start
            .trim_start_matches([' ', '\t'])
            .starts_with(line.label()));
        let _ = format!("{line:?}");
        if i < LOOKUP_LINES {
            let first = p.line(line.label()).expect("a line's label finds a line");
            assert!(first.number() <= line.number());
            assert!(p.lines_labelled(line.label()).count() >= 1);
        }
        walk_fields(&text, Holder::Line(line), line.number(), 0);
    }

    // Display: the canonical form parses to the same packet and is stable.
    let canon = p.to_string();
    if canon.len() <= MAX_PACKET {
        let q = Packet::parse(canon.as_bytes())
            .unwrap_or_else(|e| panic!("canonical form {canon:?} does not parse: {e}"));
        assert_eq!(q.to_string(), canon, "canonical form is stable");
        assert_eq!(shape(p), shape(&q), "canonical form holds the same fields");
        assert_eq!(q.priority(), p.priority());
        assert!(q.subjects().eq(p.subjects()));
    }

    walk_control(p);
}

/// A line or a group: both hold fields and answer the same getters.
#[derive(Clone, Copy)]
enum Holder<'a> {
    Line(Line<'a>),
    Group(Group<'a>, &'a str),
}

impl<'a> Holder<'a> {
    fn fields(&self) -> colony_wire::Fields<'a> {
        match self {
            Holder::Line(l) => l.fields(),
            Holder::Group(g, _) => g.fields(),
        }
    }
    /// What getters name as the label: the line's label, or the group's name.
    fn label(&self) -> &'a str {
        match self {
            Holder::Line(l) => l.label(),
            Holder::Group(_, name) => name,
        }
    }
    fn f64(&self, name: &str) -> Result<f64, FieldError> {
        match self {
            Holder::Line(l) => l.f64(name),
            Holder::Group(g, _) => g.f64(name),
        }
    }
    fn i64(&self, name: &str) -> Result<i64, FieldError> {
        match self {
            Holder::Line(l) => l.i64(name),
            Holder::Group(g, _) => g.i64(name),
        }
    }
    fn str(&self, name: &str) -> Result<std::borrow::Cow<'a, str>, FieldError> {
        match self {
            Holder::Line(l) => l.str(name),
            Holder::Group(g, _) => g.str(name),
        }
    }
    fn group(&self, name: &str) -> Result<Group<'a>, FieldError> {
        match self {
            Holder::Line(l) => l.group(name),
            Holder::Group(g, _) => g.group(name),
        }
    }
    fn get(&self, name: &str) -> Option<Value<'a>> {
        match self {
            Holder::Line(l) => l.get(name),
            Holder::Group(g, _) => g.get(name),
        }
    }
}

fn walk_fields(text: &Text<'_>, h: Holder<'_>, line: u32, depth: usize) {
    assert!(depth <= MAX_DEPTH);
    let mut names = std::collections::HashSet::new();
    for (i, f) in h.fields().enumerate() {
        assert!(!f.name.is_empty());
        assert!(names.insert(f.name), "name `{}` twice in one frame", f.name);
        let at = &text.src[f.value_at..];
        match f.value {
            Value::Bare(t) => {
                assert!(!t.is_empty());
                assert!(at.starts_with(t));
            }
            Value::Quoted(q) => {
                assert!(at.starts_with('"') && at[1..].starts_with(q.raw()));
                let _ = q.unescape();
            }
            Value::Group(g) => {
                assert!(at.starts_with('('));
                let _ = format!("{g:?}");
                walk_fields(text, Holder::Group(g, f.name), line, depth + 1);
            }
        }
        if i < GETTER_FIELDS {
            check_getters(text, &h, &f, line);
        }
    }
    // A name no field can have (names are non-empty tokens): every getter says `Missing`.
    let missing = [
        h.f64("").unwrap_err(),
        h.i64("").unwrap_err(),
        h.str("").unwrap_err(),
        h.group("").unwrap_err(),
    ];
    for e in missing {
        assert_eq!(e.kind, FieldErrorKind::Missing);
        assert_eq!(e.line, line);
        assert_eq!(e.label, h.label());
        let at = &text.src[text.offset(e.line, e.column)..];
        match h {
            Holder::Line(l) => assert!(at.starts_with(l.label()), "{e:?}"),
            Holder::Group(..) => assert!(at.starts_with('('), "{e:?}"),
        }
        let _ = e.to_string();
    }
    assert!(h.get("").is_none());
}

fn check_getters(text: &Text<'_>, h: &Holder<'_>, f: &Field<'_>, line: u32) {
    let check_err = |e: &FieldError| {
        assert_eq!(e.field, f.name);
        assert_eq!(e.label, h.label());
        assert_eq!(e.line, line);
        assert_eq!(text.offset(e.line, e.column), f.value_at, "{e:?}");
        assert!(!e.to_string().is_empty());
    };
    match (h.f64(f.name), f.value.as_f64()) {
        (Ok(a), Some(b)) => assert!(a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())),
        (Err(e), None) => {
            assert!(matches!(e.kind, FieldErrorKind::NotANumber(_)));
            check_err(&e);
        }
        other => panic!("f64 getter and as_f64 disagree on `{}`: {other:?}", f.name),
    }
    match (h.i64(f.name), f.value.as_i64()) {
        (Ok(a), Some(b)) => assert_eq!(a, b),
        (Err(e), None) => {
            assert!(matches!(e.kind, FieldErrorKind::NotAnInteger(_)));
            check_err(&e);
        }
        other => panic!("i64 getter and as_i64 disagree on `{}`: {other:?}", f.name),
    }
    match (h.str(f.name), f.value.as_str()) {
        (Ok(a), Some(b)) => assert_eq!(a, b),
        (Err(e), None) => {
            assert_eq!(e.kind, FieldErrorKind::NotAString);
            check_err(&e);
        }
        other => panic!("str getter and as_str disagree on `{}`: {other:?}", f.name),
    }
    match (h.group(f.name), f.value.as_group()) {
        (Ok(a), Some(b)) => assert!(a.fields().map(|f| f.name).eq(b.fields().map(|f| f.name))),
        (Err(e), None) => {
            assert_eq!(e.kind, FieldErrorKind::NotAGroup);
            check_err(&e);
        }
        _ => panic!("group getter and as_group disagree on `{}`", f.name),
    }
    assert!(h.get(f.name).is_some());
}

/// The packet's content without positions: labels, names and values as written.
fn shape(p: &Packet<'_>) -> Vec<(String, Vec<(String, String)>)> {
    p.lines()
        .map(|l| {
            let fields = l
                .fields()
                .map(|f| (f.name.to_owned(), format!("{:?}", f.value)))
                .collect();
            (l.label().to_owned(), fields)
        })
        .collect()
}

fn walk_control(p: &Packet<'_>) {
    if !Request::is_control(p) {
        assert_eq!(Request::parse_all(p), Err(ControlError::NotControl));
        assert!(Reply::parse(p).is_none());
    } else {
        match Request::parse_all(p) {
            Ok(requests) => {
                let bytes = Request::to_packet(&requests);
                if bytes.len() <= MAX_PACKET {
                    let q = Packet::parse(&bytes).expect("written requests parse");
                    assert_eq!(Request::parse_all(&q).as_ref(), Ok(&requests));
                }
            }
            Err(e) => {
                assert_ne!(e, ControlError::NotControl);
                let _ = e.to_string();
            }
        }
        match Reply::parse(p) {
            Some(Ok(Reply::Lease { ms })) => {
                let bytes = Reply::lease_packet(ms);
                let q = Packet::parse(&bytes).expect("a lease reply parses");
                assert_eq!(Reply::parse(&q), Some(Ok(Reply::Lease { ms })));
            }
            Some(Ok(Reply::Status(report))) => check_status_round_trip(&report),
            Some(Ok(Reply::Cookie(c))) => {
                let bytes = Reply::cookie_packet(c);
                let q = Packet::parse(&bytes).expect("a cookie reply parses");
                assert_eq!(Reply::parse(&q), Some(Ok(Reply::Cookie(c))));
            }
            Some(Err(e)) => {
                let _ = e.to_string();
            }
            None => {}
        }
    }
    // Anyone may call this on any packet; it must not panic.
    if let Ok(report) = StatusReport::from_packet(p) {
        check_status_round_trip(&report);
    }
}

fn check_status_round_trip(report: &StatusReport) {
    let bytes = report.to_packet();
    assert!(
        bytes.len() <= MAX_PACKET,
        "a status reply fits one datagram"
    );
    let q = Packet::parse(&bytes).expect("a written status reply parses");
    let back = StatusReport::from_packet(&q).expect("a written status reply reads back");
    let whole = back.drops == report.drops
        && back.channels == report.channels
        && back.clients == report.clients;
    if whole {
        assert_eq!(&back, report);
    } else {
        assert!(back.truncated, "a report cut short says so");
        assert!(report.drops.starts_with(&back.drops));
        assert!(report.channels.starts_with(&back.channels));
        assert!(report.clients.starts_with(&back.clients));
        assert_eq!(back.client_count, report.client_count);
        assert_eq!(back.uptime_ms, report.uptime_ms);
    }
}
