//! Property tests: random packets through the builder read back exactly, the
//! canonical form is stable, and no input makes the parser or a reader panic.

use colony_wire::{Fields, LineBuilder, Packet, PacketBuilder, Priority, Value, MAX_PACKET};
use proptest::prelude::*;

#[path = "../../../fuzz/walk.rs"]
mod walk;

/// A value as the test means it, before it is written.
#[derive(Debug, Clone)]
enum Model {
    Int(i64),
    Float(f64),
    /// Any text, written quoted by `field`.
    Text(String),
    /// A bare token, written by `bare`.
    Token(String),
    Group(Vec<(String, Model)>),
}

#[derive(Debug, Clone)]
struct ModelLine {
    label: String,
    fields: Vec<(String, Model)>,
}

#[derive(Debug, Clone)]
struct ModelPacket {
    subjects: Vec<String>,
    priority: i32,
    lines: Vec<ModelLine>,
}

/// Anything that can stand as a bare token: labels, names and bare values.
fn token() -> impl Strategy<Value = String> {
    prop_oneof![
        3 => "[a-z_][a-z0-9_]{0,7}",
        1 => "[^\\x00-\\x20\\x7f\"()]{1,6}",
    ]
}

/// Text of any characters, with the ones that need escapes well represented.
fn text() -> impl Strategy<Value = String> {
    let ch = prop_oneof![
        3 => any::<char>(),
        2 => prop::sample::select(vec!['"', '\\', '\n', '\r', '\t', ' ', '(', ')', '<', '@', 'n']),
        1 => prop::char::range('\0', '\u{7f}'),
    ];
    prop::collection::vec(ch, 0..12).prop_map(String::from_iter)
}

fn unique<T>(pairs: Vec<(String, T)>) -> Vec<(String, T)> {
    let mut seen = std::collections::HashSet::new();
    pairs
        .into_iter()
        .filter(|(name, _)| seen.insert(name.clone()))
        .collect()
}

fn fields(value: impl Strategy<Value = Model>) -> impl Strategy<Value = Vec<(String, Model)>> {
    prop::collection::vec((token(), value), 0..6).prop_map(unique)
}

fn model_value() -> impl Strategy<Value = Model> {
    let leaf = prop_oneof![
        any::<i64>().prop_map(Model::Int),
        any::<f64>().prop_map(Model::Float),
        prop::sample::select(vec![
            0.0,
            -0.0,
            1e300,
            -1e-300,
            5e-324,
            f64::MAX,
            f64::MIN_POSITIVE,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            0.1,
        ])
        .prop_map(Model::Float),
        text().prop_map(Model::Text),
        token().prop_map(Model::Token),
    ];
    leaf.prop_recursive(6, 40, 5, |inner| fields(inner).prop_map(Model::Group))
}

fn model_packet() -> impl Strategy<Value = ModelPacket> {
    let subjects = prop::collection::vec("[A-Za-z0-9_.:/-]{1,12}", 1..5).prop_map(|s| {
        let mut seen = std::collections::HashSet::new();
        s.into_iter().filter(|x| seen.insert(x.clone())).collect()
    });
    let priority = prop_oneof![any::<i32>(), -5i32..5];
    let line =
        (token(), fields(model_value())).prop_map(|(label, fields)| ModelLine { label, fields });
    (subjects, priority, prop::collection::vec(line, 0..6)).prop_map(
        |(subjects, priority, lines)| ModelPacket {
            subjects,
            priority,
            lines,
        },
    )
}

fn write_fields(l: &mut LineBuilder<'_>, fields: &[(String, Model)]) {
    for (name, value) in fields {
        match value {
            Model::Int(i) => l.field(name, *i),
            Model::Float(x) => l.field(name, *x),
            Model::Text(s) => l.field(name, s.as_str()),
            Model::Token(t) => l.bare(name, t),
            Model::Group(g) => l.group(name, |inner| write_fields(inner, g)),
        };
    }
}

fn build(m: &ModelPacket) -> Vec<u8> {
    let mut b = PacketBuilder::new(&m.subjects, Priority(m.priority));
    for line in &m.lines {
        write_fields(&mut b.line(&line.label), &line.fields);
    }
    b.finish().expect("a packet of valid parts builds")
}

/// What a string reads back as: the format has no escape for control
/// characters other than `\n`, `\r` and `\t`, so the builder replaces them.
fn as_written(s: &str) -> String {
    s.chars()
        .map(|c| match c {
            '\n' | '\r' | '\t' => c,
            c if (c as u32) < 0x20 || c == '\u{7f}' => '\u{fffd}',
            c => c,
        })
        .collect()
}

fn check_fields(
    got: Fields<'_>,
    want: &[(String, Model)],
    found: &dyn Fn(&str) -> bool,
) -> Result<(), TestCaseError> {
    let got: Vec<_> = got.collect();
    prop_assert_eq!(got.len(), want.len());
    for (f, (name, model)) in got.iter().zip(want) {
        prop_assert_eq!(f.name, name.as_str());
        prop_assert!(found(name), "`{}` found by name", name);
        match model {
            Model::Int(i) => {
                prop_assert!(matches!(f.value, Value::Bare(_)));
                prop_assert_eq!(f.value.as_i64(), Some(*i));
            }
            Model::Float(x) => {
                let back = f.value.as_f64().expect("a written float reads as f64");
                prop_assert!(
                    back.to_bits() == x.to_bits() || (back.is_nan() && x.is_nan()),
                    "{:?} read back as {:?}",
                    x,
                    back
                );
            }
            Model::Text(s) => {
                prop_assert!(matches!(f.value, Value::Quoted(_)));
                prop_assert_eq!(f.value.as_str().unwrap(), as_written(s));
            }
            Model::Token(t) => {
                prop_assert!(matches!(f.value, Value::Bare(b) if b == t));
            }
            Model::Group(inner) => {
                let g = f
                    .value
                    .as_group()
                    .expect("a written group reads as a group");
                check_fields(g.fields(), inner, &|n| g.get(n).is_some())?;
            }
        }
    }
    Ok(())
}

#[derive(Debug, Clone)]
enum Mutation {
    Set(usize, u8),
    Insert(usize, u8),
    Delete(usize, usize),
    Duplicate(usize, usize, usize),
    Truncate(usize),
}

fn interesting_byte() -> impl Strategy<Value = u8> {
    prop_oneof![
        3 => prop::sample::select(b"@<> ()\"\\\n\r\t\x00\x7f\xff\xc3\xa9-+.0159eE".to_vec()),
        1 => any::<u8>(),
    ]
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<usize>(), interesting_byte()).prop_map(|(p, b)| Mutation::Set(p, b)),
        (any::<usize>(), interesting_byte()).prop_map(|(p, b)| Mutation::Insert(p, b)),
        (any::<usize>(), 1usize..8).prop_map(|(p, n)| Mutation::Delete(p, n)),
        (any::<usize>(), 1usize..16, any::<usize>())
            .prop_map(|(p, n, to)| Mutation::Duplicate(p, n, to)),
        any::<usize>().prop_map(Mutation::Truncate),
    ]
}

fn mutate(bytes: &mut Vec<u8>, m: &Mutation) {
    let len = bytes.len();
    match *m {
        Mutation::Set(p, b) if len > 0 => bytes[p % len] = b,
        Mutation::Insert(p, b) => bytes.insert(p % (len + 1), b),
        Mutation::Delete(p, n) if len > 0 => {
            let start = p % len;
            bytes.drain(start..(start + n).min(len));
        }
        Mutation::Duplicate(p, n, to) if len > 0 => {
            let start = p % len;
            let piece = bytes[start..(start + n).min(len)].to_vec();
            let at = to % (len + 1);
            bytes.splice(at..at, piece);
        }
        Mutation::Truncate(p) => bytes.truncate(p % (len + 1)),
        _ => {}
    }
}

/// A body line's text with names from a small set, in any order and any subset: what `Line::pick` reads.
fn repeating_line() -> impl Strategy<Value = String> {
    let value = prop_oneof![
        any::<i64>().prop_map(|i| i.to_string()),
        any::<f64>().prop_map(|x| format!("{x:?}")),
        prop::sample::select(vec![
            "NaN",
            "inf",
            "-0",
            "1e999",
            "x",
            "\"q\"",
            "\"a\\\"b\"",
            "(a 1 b (c 2))"
        ])
        .prop_map(str::to_owned),
    ];
    let field = (
        prop::sample::select(vec!["a", "b", "c", "d", "e"]).prop_map(str::to_owned),
        value,
    );
    prop::collection::vec(field, 0..8).prop_map(|fs| {
        let fields: String = unique(fs)
            .iter()
            .map(|(n, v)| format!(" {n} {v}"))
            .collect();
        format!("l{fields}")
    })
}

/// What a getter answered, comparable across readers.
fn answer<T: std::fmt::Debug, E: std::fmt::Display>(r: Result<T, E>) -> String {
    match r {
        Ok(v) => format!("ok {v:?}"),
        Err(e) => format!("error {e}"),
    }
}

proptest! {
    #[test]
    fn picked_fields_read_as_the_lines_own(lines in prop::collection::vec(repeating_line(), 1..4)) {
        let text = format!("@ <a> 0\n{}\n", lines.join("\n"));
        let p = Packet::parse(text.as_bytes()).unwrap_or_else(|e| panic!("{e}: {text}"));
        for line in p.lines() {
            let picked = line.pick(["a", "b", "c", "d"]);
            prop_assert_eq!(picked.line().number(), line.number());
            for name in ["a", "b", "c", "d"] {
                prop_assert_eq!(format!("{:?}", picked.get(name)), format!("{:?}", line.get(name)));
                prop_assert_eq!(answer(picked.f64(name).map(f64::to_bits)), answer(line.f64(name).map(f64::to_bits)));
                prop_assert_eq!(answer(picked.i64(name)), answer(line.i64(name)));
                prop_assert_eq!(answer(picked.str(name)), answer(line.str(name)));
                prop_assert_eq!(answer(picked.group(name).map(|g| g.get("a").is_some())),
                    answer(line.group(name).map(|g| g.get("a").is_some())));
            }
            // A name not picked reads as missing, placed like the line's own missing field.
            prop_assert!(picked.get("e").is_none());
            prop_assert_eq!(answer(picked.f64("e")), answer(line.f64("zz").map_err(|e| e.to_string().replace("zz", "e"))));
        }
    }

    #[test]
    fn built_packets_read_back_field_for_field(m in model_packet()) {
        let bytes = build(&m);
        prop_assert!(bytes.len() <= MAX_PACKET);
        let p = Packet::parse(&bytes).expect("the builder's packet parses");
        prop_assert_eq!(p.subjects().collect::<Vec<_>>(), m.subjects.iter().map(String::as_str).collect::<Vec<_>>());
        prop_assert_eq!(p.priority(), Priority(m.priority));
        let lines: Vec<_> = p.lines().collect();
        prop_assert_eq!(lines.len(), m.lines.len());
        for (i, (line, want)) in lines.iter().zip(&m.lines).enumerate() {
            prop_assert_eq!(line.label(), want.label.as_str());
            prop_assert_eq!(line.number() as usize, i + 2);
            check_fields(line.fields(), &want.fields, &|n| line.get(n).is_some())?;
        }
    }

    #[test]
    fn built_packets_are_canonical_and_display_is_stable(m in model_packet()) {
        let bytes = build(&m);
        let p = Packet::parse(&bytes).unwrap();
        let shown = p.to_string();
        prop_assert_eq!(shown.as_bytes(), &bytes[..], "the builder writes the canonical form");
        let again = Packet::parse(shown.as_bytes()).unwrap().to_string();
        prop_assert_eq!(again, shown);
    }

    #[test]
    fn built_packets_survive_the_full_walk(m in model_packet()) {
        let bytes = build(&m);
        prop_assert!(walk::walk(&bytes).is_ok());
    }

    #[test]
    fn crlf_and_extra_blanks_do_not_change_what_is_read(m in model_packet()) {
        let bytes = build(&m);
        let text = std::str::from_utf8(&bytes).unwrap();
        // Only outside strings: builder strings hold no raw line ends, so every
        // `\n` is a line end; blank lines may be added between lines.
        let loose = text.replace('\n', "\r\n\r\n");
        if loose.len() <= MAX_PACKET {
            let p = Packet::parse(loose.as_bytes()).unwrap();
            prop_assert_eq!(p.to_string(), text);
        }
    }

    #[test]
    fn arbitrary_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..256)) {
        let _ = walk::walk(&bytes);
    }

    #[test]
    fn bytes_of_the_format_alphabet_never_panic(
        body in prop::collection::vec(interesting_byte(), 0..200),
        header in prop::sample::select(vec!["@ <a> 0\n", "@ <hub> 0\n", "@ <a> <b> -3\r\n", ""]),
    ) {
        let mut bytes = header.as_bytes().to_vec();
        bytes.extend(body);
        let _ = walk::walk(&bytes);
    }

    #[test]
    fn mutated_packets_never_panic(
        m in model_packet(),
        mutations in prop::collection::vec(mutation(), 1..6),
    ) {
        let mut bytes = build(&m);
        for mutation in &mutations {
            mutate(&mut bytes, mutation);
        }
        let _ = walk::walk(&bytes);
    }

    #[test]
    fn mutated_control_packets_never_panic(
        lines in prop::collection::vec(prop::sample::select(vec![
            "subscribe ch vision_out", "unsubscribe ch radio", "unsubscribe_all", "status",
            "min_priority value 5", "lease ms 5000",
            "status uptime_ms 1 lease_ms 5000 min_priority 0 clients 1 truncated 0",
            "drop reason \"malformed\" count 3", "channel ch \"a b\" packets 1 bytes 2",
            "client addr \"127.0.0.1:1\" idle_ms 0 subs (a 10 b 20)",
        ]), 0..6),
        mutations in prop::collection::vec(mutation(), 0..4),
    ) {
        let mut bytes = b"@ <hub> 0\n".to_vec();
        for l in lines {
            bytes.extend_from_slice(l.as_bytes());
            bytes.push(b'\n');
        }
        for mutation in &mutations {
            mutate(&mut bytes, mutation);
        }
        let _ = walk::walk(&bytes);
    }
}
