//! The builder: exact output, values that read back exactly, and the check in `finish`.

use colony_wire::{
    hub_packet, write_quoted, write_token_or_quoted, ErrorKind, Packet, PacketBuilder, Priority,
    Value, MAX_PACKET,
};

fn build(fill: impl FnOnce(&mut PacketBuilder)) -> Vec<u8> {
    let mut b = PacketBuilder::new(["t"], Priority(0));
    fill(&mut b);
    b.finish().expect("the builder's packet parses")
}

#[test]
fn builder_writes_the_canonical_vision_packet() {
    let mut b = PacketBuilder::new(["vision_out"], Priority(0));
    b.line("ball").field("x", 5.3).field("y", -2.5);
    b.line("blue")
        .field("id", 0)
        .field("x", 15.2)
        .field("y", -98.3)
        .field("xh", 1.0)
        .field("yh", 0.0);
    b.line("latency").field("millis", 152u32);
    let bytes = b.finish().unwrap();
    let text = "@ <vision_out> 0\n\
                ball x 5.3 y -2.5\n\
                blue id 0 x 15.2 y -98.3 xh 1.0 yh 0.0\n\
                latency millis 152\n";
    assert_eq!(std::str::from_utf8(&bytes).unwrap(), text);
    assert_eq!(Packet::parse(&bytes).unwrap().to_string(), text);
}

#[test]
fn builder_writes_subject_sets_priorities_groups_and_strings() {
    let mut b = PacketBuilder::new(["task", "robot:7"], Priority(-3));
    b.line("blue")
        .field("id", 0)
        .group("pose", |g| {
            g.field("xh", 1.0).field("yh", 0.0);
        })
        .field("note", "kick \"off\"");
    b.line("status");
    let bytes = b.finish().unwrap();
    assert_eq!(
        std::str::from_utf8(&bytes).unwrap(),
        "@ <task> <robot:7> -3\nblue id 0 pose (xh 1.0 yh 0.0) note \"kick \\\"off\\\"\"\nstatus\n"
    );
}

#[test]
fn builder_output_is_already_canonical() {
    let bytes = build(|b| {
        b.line("l")
            .field("a", 1)
            .group("g", |g| {
                g.group("h", |h| {
                    h.field("x", "y z");
                })
                .bare("t", "tok");
            })
            .group("empty", |_| {})
            .field("s", "");
    });
    let text = std::str::from_utf8(&bytes).unwrap();
    assert_eq!(
        text,
        "@ <t> 0\nl a 1 g (h (x \"y z\") t tok) empty () s \"\"\n"
    );
    assert_eq!(Packet::parse(&bytes).unwrap().to_string(), text);
}

#[test]
fn f64_values_read_back_to_the_same_bits() {
    let values = [
        0.0,
        -0.0,
        0.1,
        1.0 / 3.0,
        -98.3,
        1e300,
        -1e-300,
        1e21,
        1e-7,
        123456789012345680.0,
        f64::MAX,
        f64::MIN,
        f64::MIN_POSITIVE,
        5e-324,
        -5e-324,
        f64::EPSILON,
        f64::INFINITY,
        f64::NEG_INFINITY,
    ];
    let bytes = build(|b| {
        let mut l = b.line("n");
        for (i, v) in values.iter().enumerate() {
            l.field(&format!("v{i}"), *v);
        }
    });
    let p = Packet::parse(&bytes).unwrap();
    let n = p.line("n").unwrap();
    for (i, v) in values.iter().enumerate() {
        let back = n.f64(&format!("v{i}")).unwrap();
        assert_eq!(back.to_bits(), v.to_bits(), "{v:?} came back as {back:?}");
    }
}

#[test]
fn nan_is_written_so_that_it_reads_back_as_nan() {
    let bytes = build(|b| {
        b.line("n").field("v", f64::NAN).field("w", -f64::NAN);
    });
    let p = Packet::parse(&bytes).unwrap();
    assert!(p.line("n").unwrap().f64("v").unwrap().is_nan());
    assert!(p.line("n").unwrap().f64("w").unwrap().is_nan());
}

#[test]
fn f32_values_read_back_to_the_same_f32() {
    let values = [0.1f32, -2.5, f32::MAX, f32::MIN_POSITIVE, 1e-45, 16777217.0];
    let bytes = build(|b| {
        let mut l = b.line("n");
        for (i, v) in values.iter().enumerate() {
            l.field(&format!("v{i}"), *v);
        }
    });
    let p = Packet::parse(&bytes).unwrap();
    for (i, v) in values.iter().enumerate() {
        let back = p.line("n").unwrap().f64(&format!("v{i}")).unwrap() as f32;
        assert_eq!(back.to_bits(), v.to_bits());
    }
}

#[test]
fn integers_of_every_width_read_back_exactly() {
    let bytes = build(|b| {
        b.line("n")
            .field("i8", i8::MIN)
            .field("i16", i16::MIN)
            .field("i32", i32::MIN)
            .field("i64min", i64::MIN)
            .field("i64max", i64::MAX)
            .field("u8", u8::MAX)
            .field("u16", u16::MAX)
            .field("u32", u32::MAX)
            .field("usize", 12usize)
            .field("isize", -12isize)
            .field("u64", u64::MAX);
    });
    let p = Packet::parse(&bytes).unwrap();
    let n = p.line("n").unwrap();
    assert_eq!(n.i64("i8").unwrap(), i8::MIN as i64);
    assert_eq!(n.i64("i16").unwrap(), i16::MIN as i64);
    assert_eq!(n.i64("i32").unwrap(), i32::MIN as i64);
    assert_eq!(n.i64("i64min").unwrap(), i64::MIN);
    assert_eq!(n.i64("i64max").unwrap(), i64::MAX);
    assert_eq!(n.i64("u8").unwrap(), 255);
    assert_eq!(n.i64("u16").unwrap(), 65535);
    assert_eq!(n.i64("u32").unwrap(), u32::MAX as i64);
    assert_eq!(n.i64("usize").unwrap(), 12);
    assert_eq!(n.i64("isize").unwrap(), -12);
    // Past i64 the text is still exact; only the i64 getter cannot hold it.
    assert_eq!(n.str("u64").unwrap(), "18446744073709551615");
    assert_eq!(n.str("u64").unwrap().parse::<u64>().unwrap(), u64::MAX);
    assert!(n.i64("u64").is_err());
}

#[test]
fn bools_are_written_as_words() {
    let bytes = build(|b| {
        b.line("flags").field("on", true).field("off", false);
    });
    let p = Packet::parse(&bytes).unwrap();
    let l = p.line("flags").unwrap();
    assert_eq!(l.str("on").unwrap(), "true");
    assert_eq!(l.str("off").unwrap(), "false");
}

#[test]
fn strings_with_quotes_backslashes_and_line_ends_read_back_exactly() {
    let strings = [
        "",
        "plain",
        "two words",
        "kick \"off\"",
        "C:\\path\\",
        "\\\"",
        "line one\nline two\r\n",
        "tab\there",
        "(parens) <angles> @at",
        "é 漢字 🤖 \u{85} \u{2028}",
        "\"",
        "\\",
        "ends with backslash \\",
    ];
    let bytes = build(|b| {
        let mut l = b.line("s");
        for (i, s) in strings.iter().enumerate() {
            l.field(&format!("v{i}"), *s);
        }
        b.line("owned").field("v", String::from("a \"b\""));
    });
    assert_eq!(
        bytes.iter().filter(|&&c| c == b'\n').count(),
        3,
        "line ends inside strings are escaped"
    );
    let p = Packet::parse(&bytes).unwrap();
    let l = p.line("s").unwrap();
    for (i, s) in strings.iter().enumerate() {
        assert_eq!(l.str(&format!("v{i}")).unwrap(), *s);
    }
    assert_eq!(p.line("owned").unwrap().str("v").unwrap(), "a \"b\"");
}

#[test]
fn control_characters_other_than_line_ends_and_tab_become_replacement_characters() {
    // The format has no escape for them; the builder must still produce a valid packet.
    let bytes = build(|b| {
        b.line("s").field("v", "a\u{0}b\u{1b}c\u{7f}d");
    });
    let p = Packet::parse(&bytes).unwrap();
    assert_eq!(
        p.line("s").unwrap().str("v").unwrap(),
        "a\u{fffd}b\u{fffd}c\u{fffd}d"
    );
}

#[test]
fn write_quoted_escapes_exactly_the_five_escapes() {
    let mut out = String::new();
    write_quoted(&mut out, "a\"b\\c\nd\re\tf");
    assert_eq!(out, r#""a\"b\\c\nd\re\tf""#);
}

#[test]
fn write_token_or_quoted_quotes_only_when_needed() {
    let cases = [
        ("abc", "abc"),
        ("-2.5", "-2.5"),
        ("é", "é"),
        ("", "\"\""),
        ("a b", "\"a b\""),
        ("a(b", "\"a(b\""),
        ("a)", "\"a)\""),
        ("say\"", "\"say\\\"\""),
        ("tab\t", "\"tab\\t\""),
    ];
    for (input, written) in cases {
        let mut out = String::new();
        write_token_or_quoted(&mut out, input);
        assert_eq!(out, written, "for {input:?}");
        let text = format!("@ <a> 0\nl v {out}\n");
        let p = Packet::parse(text.as_bytes()).unwrap();
        assert_eq!(p.line("l").unwrap().str("v").unwrap(), input);
    }
}

#[test]
fn bare_writes_the_token_as_is() {
    let bytes = build(|b| {
        b.line("l").bare("mode", "fast").bare("x", "1e3");
    });
    let p = Packet::parse(&bytes).unwrap();
    let l = p.line("l").unwrap();
    assert!(matches!(l.get("mode").unwrap(), Value::Bare("fast")));
    assert_eq!(l.f64("x").unwrap(), 1000.0);
}

#[test]
fn raw_line_is_appended_verbatim() {
    let mut b = PacketBuilder::new(["vision_out"], Priority(0));
    b.raw_line("ball x 5.3 y -2.5").raw_line("latency millis 1");
    b.line("blue").field("id", 3);
    assert_eq!(
        b.as_str(),
        "@ <vision_out> 0\nball x 5.3 y -2.5\nlatency millis 1\nblue id 3"
    );
    let bytes = b.finish().unwrap();
    assert!(bytes.ends_with(b"blue id 3\n"));
    let p = Packet::parse(&bytes).unwrap();
    assert_eq!(p.lines().count(), 3);
}

#[test]
fn finish_rejects_a_duplicate_name() {
    let mut b = PacketBuilder::new(["a"], Priority(0));
    b.line("ball").field("x", 1).field("x", 2);
    let e = b.finish().unwrap_err();
    assert_eq!(e.kind, ErrorKind::DuplicateName { name: "x".into() });
    assert_eq!((e.line, e.column), (2, 10));
}

#[test]
fn finish_rejects_a_bad_subject() {
    let b = PacketBuilder::new(["no spaces"], Priority(0));
    assert_eq!(
        b.finish().unwrap_err().kind,
        ErrorKind::BadSubject("no spaces".into())
    );
    let b = PacketBuilder::new(Vec::<String>::new(), Priority(0));
    assert_eq!(
        b.finish().unwrap_err().kind,
        ErrorKind::BadHeader("a `<subject>`")
    );
}

#[test]
fn finish_rejects_a_name_that_is_not_a_token() {
    let mut b = PacketBuilder::new(["a"], Priority(0));
    b.line("l").field("two words", 1);
    assert_eq!(
        b.finish().unwrap_err().kind,
        ErrorKind::MissingValue { name: "1".into() }
    );
    let mut b = PacketBuilder::new(["a"], Priority(0));
    b.line("l").field("", 1);
    assert!(b.finish().is_err());
}

#[test]
fn finish_rejects_a_packet_larger_than_a_datagram() {
    let mut b = PacketBuilder::new(["a"], Priority(0));
    b.line("pad").field("s", "x".repeat(MAX_PACKET));
    assert!(matches!(
        b.finish().unwrap_err().kind,
        ErrorKind::TooLarge { .. }
    ));
}

#[test]
fn hub_packet_starts_a_control_packet() {
    let mut b = hub_packet();
    b.line("subscribe").bare("ch", "vision_out");
    let bytes = b.finish().unwrap();
    assert_eq!(bytes, b"@ <hub> 0\nsubscribe ch vision_out\n");
}

#[test]
fn subjects_may_be_given_as_strings_or_subject_values() {
    let subjects: Vec<colony_wire::Subject> = vec!["a".parse().unwrap(), "b".parse().unwrap()];
    let b = PacketBuilder::new(&subjects, Priority(1));
    assert_eq!(b.finish().unwrap(), b"@ <a> <b> 1\n");
    let b = PacketBuilder::new(vec![String::from("c")], Priority(2));
    assert_eq!(b.finish().unwrap(), b"@ <c> 2\n");
}

#[test]
fn subject_accepts_names_with_or_without_brackets() {
    use colony_wire::Subject;
    assert_eq!(Subject::new("<vision_out>").unwrap().as_str(), "vision_out");
    assert_eq!(
        Subject::new("vision_out").unwrap().to_string(),
        "vision_out"
    );
    assert!(Subject::new("<>").is_err());
    assert!(Subject::new("<a").is_err());
    assert!(Subject::new(&"s".repeat(65)).is_err());
    assert_eq!(
        Subject::new("a b").unwrap_err().to_string(),
        "`a b` is not a subject: use 1 to 64 characters of A-Z a-z 0-9 _ - . : /"
    );
}
