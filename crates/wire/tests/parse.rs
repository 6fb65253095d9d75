//! The parser: headers, bodies, values, limits, every error with its position,
//! typed getters and the canonical `Display`.

use std::borrow::Cow;

use colony_wire::{
    ErrorKind, FieldError, FieldErrorKind, Packet, ParseError, Priority, Value, MAX_DEPTH,
    MAX_PACKET, MAX_SUBJECTS, MAX_SUBJECT_LEN,
};

/// The paper's example packet, in canonical form.
const VISION: &str = "@ <vision_out> 0\n\
ball x 5.3 y -2.5\n\
blue id 0 x 15.2 y -98.3 xh 1.0 yh 0.0\n\
blue id 1 x -40.5 y 12.0 xh 0.0 yh 1.0\n\
yellow id 0 x 80.1 y 3.25 xh -1.0 yh 0.0\n\
latency millis 152\n";

fn parse(text: &str) -> Packet<'_> {
    Packet::parse(text.as_bytes()).unwrap_or_else(|e| panic!("{text:?} should parse: {e}"))
}

fn err(bytes: impl AsRef<[u8]>) -> ParseError {
    match Packet::parse(bytes.as_ref()) {
        Ok(p) => panic!("{:?} should be rejected", p.as_str()),
        Err(e) => e,
    }
}

/// Asserts the error's kind, line and column in one go.
fn assert_err(bytes: impl AsRef<[u8]>, kind: ErrorKind, line: u32, column: u32) {
    let bytes = bytes.as_ref();
    let e = err(bytes);
    assert_eq!(
        e,
        ParseError { kind, line, column },
        "for {:?}",
        String::from_utf8_lossy(bytes)
    );
}

fn bare<'a>(v: Value<'a>) -> &'a str {
    match v {
        Value::Bare(t) => t,
        other => panic!("expected a bare token, got {other:?}"),
    }
}

// ---------------------------------------------------------------- the paper's packet

#[test]
fn papers_vision_packet_reads_every_field() {
    let p = parse(VISION);
    assert_eq!(p.subjects().collect::<Vec<_>>(), ["vision_out"]);
    assert_eq!(p.subject_count(), 1);
    assert_eq!(p.priority(), Priority(0));
    assert_eq!(p.as_str(), VISION);

    let labels: Vec<_> = p.lines().map(|l| l.label()).collect();
    assert_eq!(labels, ["ball", "blue", "blue", "yellow", "latency"]);

    let ball = p.line("ball").unwrap();
    assert_eq!(ball.number(), 2);
    assert_eq!(ball.f64("x").unwrap(), 5.3);
    assert_eq!(ball.f64("y").unwrap(), -2.5);

    let blue: Vec<_> = p.lines_labelled("blue").collect();
    assert_eq!(blue.len(), 2, "repeated labels are an array");
    assert_eq!(blue[0].i64("id").unwrap(), 0);
    assert_eq!(blue[0].f64("x").unwrap(), 15.2);
    assert_eq!(blue[0].f64("y").unwrap(), -98.3);
    assert_eq!(blue[0].f64("xh").unwrap(), 1.0);
    assert_eq!(blue[0].f64("yh").unwrap(), 0.0);
    assert_eq!(blue[1].i64("id").unwrap(), 1);
    assert_eq!(blue[1].f64("x").unwrap(), -40.5);
    assert_eq!(blue[1].number(), 4);

    let yellow = p.line("yellow").unwrap();
    assert_eq!(yellow.f64("y").unwrap(), 3.25);
    assert_eq!(yellow.f64("xh").unwrap(), -1.0);

    let latency = p.line("latency").unwrap();
    assert_eq!(latency.i64("millis").unwrap(), 152);
    assert_eq!(latency.number(), 6);

    assert!(p.line("radio").is_none());
    assert_eq!(p.lines_labelled("radio").count(), 0);
}

#[test]
fn fields_come_in_the_order_written_with_their_offsets() {
    let p = parse(VISION);
    let blue = p.line("blue").unwrap();
    let fields: Vec<_> = blue.fields().collect();
    let names: Vec<_> = fields.iter().map(|f| f.name).collect();
    assert_eq!(names, ["id", "x", "y", "xh", "yh"]);
    let values: Vec<_> = fields.iter().map(|f| bare(f.value)).collect();
    assert_eq!(values, ["0", "15.2", "-98.3", "1.0", "0.0"]);
    for f in &fields {
        assert!(VISION[f.value_at..].starts_with(bare(f.value)));
    }
    assert_eq!(bare(blue.get("xh").unwrap()), "1.0");
    assert!(blue.get("zz").is_none());
}

#[test]
fn header_only_packet_has_no_lines() {
    let p = parse("@ <vision_out> 0\n");
    assert_eq!(p.lines().count(), 0);
    let p = parse("@ <vision_out> 0");
    assert_eq!(p.lines().count(), 0, "the final line end is optional");
}

#[test]
fn line_without_fields_is_just_a_label() {
    let p = parse("@ <hub> 0\nstatus\nunsubscribe_all   \n");
    let labels: Vec<_> = p.lines().map(|l| l.label()).collect();
    assert_eq!(labels, ["status", "unsubscribe_all"]);
    assert_eq!(p.line("status").unwrap().fields().count(), 0);
}

#[test]
fn unicode_labels_names_and_bare_values_are_tokens() {
    let p = parse("@ <a> 0\nroböter größe 1,5 ✓ ja\n");
    let l = p.line("roböter").unwrap();
    assert_eq!(l.str("größe").unwrap(), "1,5");
    assert_eq!(l.str("✓").unwrap(), "ja");
}

// ---------------------------------------------------------------- subjects

#[test]
fn several_subjects_form_a_subject_set_in_written_order() {
    let p = parse("@ <task> <robot:7> <arm/left> 2\nannounce id 9\n");
    assert_eq!(
        p.subjects().collect::<Vec<_>>(),
        ["task", "robot:7", "arm/left"]
    );
    assert_eq!(p.subject_count(), 3);
    assert!(p.has_subject("robot:7"));
    assert!(p.has_subject("arm/left"));
    assert!(!p.has_subject("robot"));
    assert!(!p.has_subject("<task>"));
    assert_eq!(p.subjects_text(), "<task> <robot:7> <arm/left>");
}

#[test]
fn subjects_text_is_kept_as_written_and_display_normalises_blanks() {
    let p = parse("@\t<a>  \t<b>   7\n");
    assert_eq!(p.subjects_text(), "<a>  \t<b>");
    assert_eq!(p.subjects().collect::<Vec<_>>(), ["a", "b"]);
    assert_eq!(p.to_string(), "@ <a> <b> 7\n");
}

#[test]
fn every_subject_character_is_accepted() {
    let name = "Az09_-.:/";
    let text = format!("@ <{name}> 0\n");
    assert_eq!(parse(&text).subjects().next(), Some(name));
}

#[test]
fn sixteen_subjects_are_accepted_and_a_seventeenth_is_rejected() {
    let names: Vec<String> = (0..MAX_SUBJECTS).map(|i| format!("<s{i:02}>")).collect();
    let text = format!("@ {} 0\n", names.join(" "));
    assert_eq!(parse(&text).subject_count(), MAX_SUBJECTS);

    let text = format!("@ {} <s99> 0\n", names.join(" "));
    let column = text.find("<s99>").unwrap() as u32 + 1;
    assert_err(
        &text,
        ErrorKind::BadHeader("at most 16 subjects"),
        1,
        column,
    );
}

#[test]
fn subject_of_the_longest_length_is_accepted_and_one_longer_is_rejected() {
    let longest = "s".repeat(MAX_SUBJECT_LEN);
    assert!(Packet::parse(format!("@ <{longest}> 0\n").as_bytes()).is_ok());
    let too_long = "s".repeat(MAX_SUBJECT_LEN + 1);
    assert_err(
        format!("@ <{too_long}> 0\n"),
        ErrorKind::BadSubject(too_long),
        1,
        3,
    );
}

#[test]
fn subject_with_a_blank_is_rejected_at_its_bracket() {
    assert_err(
        "@ <vision out> 0\n",
        ErrorKind::BadSubject("vision out".into()),
        1,
        3,
    );
}

#[test]
fn empty_subject_is_rejected() {
    assert_err("@ <> 0\n", ErrorKind::BadSubject(String::new()), 1, 3);
}

#[test]
fn subject_with_a_disallowed_character_is_rejected() {
    assert_err("@ <a> <b*c> 0\n", ErrorKind::BadSubject("b*c".into()), 1, 7);
}

#[test]
fn duplicate_subject_is_rejected_at_its_second_appearance() {
    assert_err(
        "@ <a> <b> <a> 0\n",
        ErrorKind::DuplicateSubject("a".into()),
        1,
        11,
    );
}

// ---------------------------------------------------------------- priorities

#[test]
fn priority_is_read_as_a_signed_32_bit_integer() {
    assert_eq!(parse("@ <a> 0\n").priority(), Priority(0));
    assert_eq!(parse("@ <a> 42\n").priority(), Priority(42));
    assert_eq!(parse("@ <a> -7\n").priority(), Priority(-7));
    assert_eq!(parse("@ <a> +5\n").priority(), Priority(5));
    assert_eq!(parse("@ <a> 2147483647\n").priority(), Priority(i32::MAX));
    assert_eq!(parse("@ <a> -2147483648\n").priority(), Priority(i32::MIN));
}

#[test]
fn priorities_order_lowest_first() {
    assert!(Priority(-3) < Priority(0));
    assert!(Priority(i32::MIN) < Priority(i32::MAX));
    assert_eq!(Priority::default(), Priority(0));
    assert_eq!(Priority(-12).to_string(), "-12");
}

#[test]
fn priority_out_of_range_is_rejected_with_its_text() {
    assert_err(
        "@ <a> 2147483648\n",
        ErrorKind::BadPriority("2147483648".into()),
        1,
        7,
    );
    assert_err(
        "@ <a> -2147483649\n",
        ErrorKind::BadPriority("-2147483649".into()),
        1,
        7,
    );
}

#[test]
fn priority_that_is_not_an_integer_is_rejected() {
    assert_err("@ <a> 1.5\n", ErrorKind::BadPriority("1.5".into()), 1, 7);
    assert_err("@ <a> high\n", ErrorKind::BadPriority("high".into()), 1, 7);
    assert_err("@ <a>  -\n", ErrorKind::BadPriority("-".into()), 1, 8);
}

#[test]
fn quoted_priority_is_rejected_as_a_bad_header() {
    assert_err(
        "@ <a> \"0\"\n",
        ErrorKind::BadHeader("an integer priority"),
        1,
        7,
    );
}

// ---------------------------------------------------------------- header errors

#[test]
fn packet_not_starting_with_at_is_rejected_at_column_one() {
    assert_err(
        "ball x 1\n",
        ErrorKind::BadHeader("`@` at the start of the packet"),
        1,
        1,
    );
    assert_err(
        " @ <a> 0\n",
        ErrorKind::BadHeader("`@` at the start of the packet"),
        1,
        1,
    );
}

#[test]
fn at_sign_without_a_blank_after_it_is_rejected() {
    assert_err("@<a> 0\n", ErrorKind::BadHeader("a blank after `@`"), 1, 2);
    assert_err("@", ErrorKind::BadHeader("a blank after `@`"), 1, 2);
}

#[test]
fn header_without_a_subject_is_rejected() {
    assert_err("@ 0\n", ErrorKind::BadHeader("a `<subject>`"), 1, 3);
    assert_err("@ \n", ErrorKind::BadHeader("a `<subject>`"), 1, 3);
}

#[test]
fn unclosed_subject_is_rejected_at_its_bracket() {
    assert_err(
        "@ <a> <b 0\nx y >\n",
        ErrorKind::BadHeader("`>` to close the subject"),
        1,
        7,
    );
}

#[test]
fn subjects_must_be_separated_by_blanks() {
    assert_err(
        "@ <a><b> 0\n",
        ErrorKind::BadHeader("a blank after the subject"),
        1,
        6,
    );
    assert_err(
        "@ <a>0\n",
        ErrorKind::BadHeader("a blank after the subject"),
        1,
        6,
    );
}

#[test]
fn header_without_a_priority_is_rejected() {
    assert_err(
        "@ <a>\nball x 1\n",
        ErrorKind::BadHeader("an integer priority after the subjects"),
        1,
        6,
    );
    assert_err(
        "@ <a>",
        ErrorKind::BadHeader("an integer priority after the subjects"),
        1,
        6,
    );
    assert_err(
        "@ <a> \n",
        ErrorKind::BadHeader("an integer priority"),
        1,
        7,
    );
}

#[test]
fn anything_after_the_priority_is_rejected() {
    assert_err(
        "@ <a> 0 x\n",
        ErrorKind::BadHeader("the end of the header after the priority"),
        1,
        8,
    );
    assert_err(
        "@ <a> 0 <b>\n",
        ErrorKind::BadHeader("the end of the header after the priority"),
        1,
        8,
    );
}

// ---------------------------------------------------------------- line ends and blank lines

#[test]
fn crlf_line_ends_read_like_lf() {
    let crlf = VISION.replace('\n', "\r\n");
    let p = parse(&crlf);
    assert_eq!(p.lines().count(), 5);
    assert_eq!(p.line("latency").unwrap().i64("millis").unwrap(), 152);
    assert_eq!(p.line("latency").unwrap().number(), 6);
    assert_eq!(p.line("ball").unwrap().str("y").unwrap(), "-2.5");
    assert_eq!(p.to_string(), VISION, "display writes \\n line ends");
}

#[test]
fn mixed_line_ends_are_accepted() {
    let p = parse("@ <a> 0\r\nball x 1\nblue x 2\r\n");
    assert_eq!(p.lines().count(), 2);
    assert_eq!(p.line("blue").unwrap().f64("x").unwrap(), 2.0);
}

#[test]
fn lone_carriage_return_is_a_control_character() {
    assert_err(
        "@ <a> 0\nball x 1\ry 2\n",
        ErrorKind::ControlChar(b'\r'),
        2,
        9,
    );
    assert_err("@ <a> 0\r", ErrorKind::ControlChar(b'\r'), 1, 8);
}

#[test]
fn blank_lines_are_skipped_but_counted() {
    let text = "@ <a> 0\n\nball x 1\n   \n\t\n\r\nblue x 2\n\n";
    let p = parse(text);
    let lines: Vec<_> = p.lines().map(|l| (l.label(), l.number())).collect();
    assert_eq!(lines, [("ball", 3), ("blue", 7)]);
    assert_eq!(p.to_string(), "@ <a> 0\nball x 1\nblue x 2\n");
}

#[test]
fn blanks_and_tabs_separate_tokens() {
    let p = parse("@ <a> 0\n  ball\tx  5.3 \t y\t-2.5  \n");
    let ball = p.line("ball").unwrap();
    assert_eq!(ball.f64("x").unwrap(), 5.3);
    assert_eq!(ball.f64("y").unwrap(), -2.5);
    assert_eq!(p.to_string(), "@ <a> 0\nball x 5.3 y -2.5\n");
}

// ---------------------------------------------------------------- quoted strings

#[test]
fn quoted_string_resolves_every_escape() {
    let p = parse(
        r#"@ <a> 0
note text "q\" b\\ n\n r\r t\t end"
"#,
    );
    let note = p.line("note").unwrap();
    assert_eq!(note.str("text").unwrap(), "q\" b\\ n\n r\r t\t end");
    match note.get("text").unwrap() {
        Value::Quoted(q) => assert_eq!(q.raw(), r#"q\" b\\ n\n r\r t\t end"#),
        other => panic!("expected a quoted string, got {other:?}"),
    }
}

#[test]
fn quoted_string_without_escapes_is_borrowed() {
    let p = parse("@ <a> 0\nnote text \"kick off (now)\"\n");
    let text = p.line("note").unwrap().str("text").unwrap();
    assert!(matches!(text, Cow::Borrowed("kick off (now)")));
}

#[test]
fn quoted_string_with_escapes_is_owned() {
    let p = parse("@ <a> 0\nnote text \"a\\\\b\"\n");
    let text = p.line("note").unwrap().str("text").unwrap();
    assert!(matches!(text, Cow::Owned(ref s) if s == "a\\b"));
}

#[test]
fn empty_quoted_string_is_an_empty_value() {
    let p = parse("@ <a> 0\nnote text \"\" after 1\n");
    let note = p.line("note").unwrap();
    assert_eq!(note.str("text").unwrap(), "");
    assert_eq!(note.i64("after").unwrap(), 1);
}

#[test]
fn quoted_string_keeps_delimiters_and_unicode() {
    let p = parse("@ <a> 0\nnote text \"@ <x> ( ) ' é 漢字 🤖\"\n");
    assert_eq!(
        p.line("note").unwrap().str("text").unwrap(),
        "@ <x> ( ) ' é 漢字 🤖"
    );
}

#[test]
fn quoted_value_may_touch_its_name_and_the_next_name() {
    let p = parse("@ <a> 0\nnote a\"x\"b\"y\"c 1\n");
    let note = p.line("note").unwrap();
    assert_eq!(note.str("a").unwrap(), "x");
    assert_eq!(note.str("b").unwrap(), "y");
    assert_eq!(note.i64("c").unwrap(), 1);
    assert_eq!(p.to_string(), "@ <a> 0\nnote a \"x\" b \"y\" c 1\n");
}

#[test]
fn raw_tab_inside_a_quoted_string_is_kept() {
    // ErrorKind::ControlChar: "a raw control character (other than tab and the
    // line end)". `printf 'note text "a\tb"'` sends a raw tab.
    let p = parse("@ <a> 0\nnote text \"a\tb\"\n");
    assert_eq!(p.line("note").unwrap().str("text").unwrap(), "a\tb");
    assert_eq!(p.to_string(), "@ <a> 0\nnote text \"a\tb\"\n");
}

#[test]
fn unterminated_string_is_rejected_at_its_opening_quote() {
    assert_err(
        "@ <a> 0\nnote text \"abc\nnext x 1\n",
        ErrorKind::UnterminatedString,
        2,
        11,
    );
    assert_err(
        "@ <a> 0\nnote text \"abc",
        ErrorKind::UnterminatedString,
        2,
        11,
    );
    assert_err(
        "@ <a> 0\nnote text \"abc\r\n",
        ErrorKind::UnterminatedString,
        2,
        11,
    );
}

#[test]
fn string_ending_in_a_backslash_is_unterminated() {
    assert_err(
        "@ <a> 0\nnote text \"abc\\\"\n",
        ErrorKind::UnterminatedString,
        2,
        11,
    );
    assert_err(
        "@ <a> 0\nnote text \"abc\\\n",
        ErrorKind::UnterminatedString,
        2,
        11,
    );
    assert_err(
        "@ <a> 0\nnote text \"abc\\",
        ErrorKind::UnterminatedString,
        2,
        11,
    );
}

#[test]
fn unknown_escape_is_rejected_at_its_backslash() {
    assert_err(
        "@ <a> 0\nnote text \"ab\\qc\"\n",
        ErrorKind::BadEscape('q'),
        2,
        14,
    );
    assert_err(
        "@ <a> 0\nnote text \"\\é\"\n",
        ErrorKind::BadEscape('é'),
        2,
        12,
    );
    assert_err(
        "@ <a> 0\nnote text \"\\u0041\"\n",
        ErrorKind::BadEscape('u'),
        2,
        12,
    );
}

#[test]
fn control_character_inside_a_string_is_rejected_where_it_stands() {
    assert_err(
        "@ <a> 0\nnote text \"a\x01b\"\n",
        ErrorKind::ControlChar(0x01),
        2,
        13,
    );
    assert_err(
        "@ <a> 0\nnote text \"a\x7fb\"\n",
        ErrorKind::ControlChar(0x7f),
        2,
        13,
    );
}

// ---------------------------------------------------------------- groups

#[test]
fn nested_groups_read_through_getters_and_iterators() {
    let p = parse("@ <a> 0\nblue id 0 pose (x 1.5 y -2 h (c 1.0 s 0.0)) name \"b0\"\n");
    let blue = p.line("blue").unwrap();
    let pose = blue.group("pose").unwrap();
    assert_eq!(pose.f64("x").unwrap(), 1.5);
    assert_eq!(pose.i64("y").unwrap(), -2);
    let h = pose.group("h").unwrap();
    assert_eq!(h.f64("c").unwrap(), 1.0);
    assert_eq!(h.f64("s").unwrap(), 0.0);
    assert_eq!(h.str("c").unwrap(), "1.0");
    assert_eq!(
        blue.str("name").unwrap(),
        "b0",
        "fields after a group are read"
    );
    let names: Vec<_> = pose.fields().map(|f| f.name).collect();
    assert_eq!(names, ["x", "y", "h"]);
    assert!(blue.get("pose").unwrap().as_group().is_some());
    assert_eq!(
        pose.get("h").unwrap().as_group().unwrap().fields().count(),
        2
    );
    assert_eq!(
        format!("{h:?}"),
        r#"[("c", Bare("1.0")), ("s", Bare("0.0"))]"#
    );
}

#[test]
fn group_names_are_scoped_to_their_group() {
    let p = parse("@ <a> 0\nl x 1 g (x 2 g (x 3))\n");
    let l = p.line("l").unwrap();
    assert_eq!(l.i64("x").unwrap(), 1);
    assert_eq!(l.group("g").unwrap().i64("x").unwrap(), 2);
    assert_eq!(
        l.group("g").unwrap().group("g").unwrap().i64("x").unwrap(),
        3
    );
}

#[test]
fn empty_group_has_no_fields() {
    let p = parse("@ <a> 0\nl g () h ( ) k 1\n");
    let l = p.line("l").unwrap();
    assert_eq!(l.group("g").unwrap().fields().count(), 0);
    assert_eq!(l.group("h").unwrap().fields().count(), 0);
    assert_eq!(l.i64("k").unwrap(), 1);
    assert_eq!(p.to_string(), "@ <a> 0\nl g () h () k 1\n");
}

#[test]
fn group_blanks_are_optional_and_display_tidies_them() {
    let p = parse("@ <a> 0\nl g(  x 1   y 2 )k 3\n");
    let l = p.line("l").unwrap();
    assert_eq!(l.group("g").unwrap().i64("y").unwrap(), 2);
    assert_eq!(l.i64("k").unwrap(), 3);
    assert_eq!(p.to_string(), "@ <a> 0\nl g (x 1 y 2) k 3\n");
}

fn nested(depth: usize) -> String {
    let mut line = String::from("deep ");
    for i in 0..depth {
        line.push_str(&format!("g{i} ("));
    }
    line.push_str("leaf 1");
    line.push_str(&")".repeat(depth));
    format!("@ <a> 0\n{line}\n")
}

#[test]
fn groups_nest_down_to_the_depth_limit() {
    let text = nested(MAX_DEPTH);
    let p = parse(&text);
    let line = p.line("deep").unwrap();
    let mut g = line.group("g0").unwrap();
    for i in 1..MAX_DEPTH {
        g = g.group(&format!("g{i}")).unwrap();
    }
    assert_eq!(g.i64("leaf").unwrap(), 1);
    assert_eq!(p.to_string(), text);
}

#[test]
fn group_one_deeper_than_the_limit_is_rejected_at_its_paren() {
    let text = nested(MAX_DEPTH + 1);
    let column = text
        .lines()
        .nth(1)
        .unwrap()
        .match_indices('(')
        .nth(MAX_DEPTH)
        .unwrap()
        .0 as u32
        + 1;
    assert_err(&text, ErrorKind::TooDeep, 2, column);
}

#[test]
fn unclosed_group_is_rejected_at_the_line_end() {
    assert_err("@ <a> 0\nl g (x 1\nm y 2\n", ErrorKind::UnclosedGroup, 2, 9);
    assert_err("@ <a> 0\nl g (x 1", ErrorKind::UnclosedGroup, 2, 9);
    assert_err(
        "@ <a> 0\nl g (x 1 h (y 2)\r\n",
        ErrorKind::UnclosedGroup,
        2,
        17,
    );
}

#[test]
fn unmatched_close_is_rejected_where_it_stands() {
    assert_err("@ <a> 0\nl x 1 )\n", ErrorKind::UnmatchedClose, 2, 7);
    assert_err(
        "@ <a> 0\nl g (x 1)) y 2\n",
        ErrorKind::UnmatchedClose,
        2,
        10,
    );
}

// ---------------------------------------------------------------- body errors

#[test]
fn line_starting_with_a_paren_or_quote_has_no_label() {
    assert_err("@ <a> 0\n(x 1)\n", ErrorKind::ExpectedLabel('('), 2, 1);
    assert_err(
        "@ <a> 0\nball x 1\n  \"ball\" x 1\n",
        ErrorKind::ExpectedLabel('"'),
        3,
        3,
    );
    assert_err("@ <a> 0\n)\n", ErrorKind::ExpectedLabel(')'), 2, 1);
}

#[test]
fn quoted_or_grouped_name_is_rejected_where_it_stands() {
    assert_err(
        "@ <a> 0\nball x 1 \"y\" 2\n",
        ErrorKind::ExpectedName('"'),
        2,
        10,
    );
    assert_err(
        "@ <a> 0\nball x 1 (y 2)\n",
        ErrorKind::ExpectedName('('),
        2,
        10,
    );
    assert_err(
        "@ <a> 0\nball g (\"y\" 2)\n",
        ErrorKind::ExpectedName('"'),
        2,
        9,
    );
}

#[test]
fn name_at_the_end_of_its_line_is_missing_its_value() {
    assert_err(
        "@ <a> 0\nball x 1 y\nblue x 2\n",
        ErrorKind::MissingValue { name: "y".into() },
        2,
        10,
    );
    assert_err(
        "@ <a> 0\nball x 1 y",
        ErrorKind::MissingValue { name: "y".into() },
        2,
        10,
    );
    assert_err(
        "@ <a> 0\r\nball x 1 y  \r\n",
        ErrorKind::MissingValue { name: "y".into() },
        2,
        10,
    );
}

#[test]
fn name_at_the_end_of_its_group_is_missing_its_value() {
    assert_err(
        "@ <a> 0\nball g (x 1 y) z 2\n",
        ErrorKind::MissingValue { name: "y".into() },
        2,
        13,
    );
    assert_err(
        "@ <a> 0\nball x )\n",
        ErrorKind::MissingValue { name: "x".into() },
        2,
        6,
    );
}

#[test]
fn duplicate_name_on_a_line_is_rejected_with_its_column() {
    assert_err(
        "@ <a> 0\nball x 1 y 2 x 3\n",
        ErrorKind::DuplicateName { name: "x".into() },
        2,
        14,
    );
}

#[test]
fn duplicate_name_in_a_group_is_rejected_with_its_column() {
    assert_err(
        "@ <a> 0\nball g (x 1 x 2)\n",
        ErrorKind::DuplicateName { name: "x".into() },
        2,
        13,
    );
}

#[test]
fn duplicate_name_past_many_fields_is_still_found() {
    // Past a handful of names the parser switches to a hash set; both paths must agree.
    let mut line = String::from("wide");
    for i in 0..40 {
        line.push_str(&format!(" f{i} {i}"));
    }
    let column = line.len() as u32 + 2;
    line.push_str(" f3 0");
    assert_err(
        format!("@ <a> 0\n{line}\n"),
        ErrorKind::DuplicateName { name: "f3".into() },
        2,
        column,
    );
}

#[test]
fn a_name_may_repeat_across_lines() {
    let p = parse("@ <a> 0\nball x 1\nball x 2\n");
    let xs: Vec<_> = p
        .lines_labelled("ball")
        .map(|l| l.i64("x").unwrap())
        .collect();
    assert_eq!(xs, [1, 2]);
}

#[test]
fn control_character_in_the_body_is_rejected_where_it_stands() {
    assert_err(
        "@ <a> 0\nball x\x01 1\n",
        ErrorKind::ControlChar(0x01),
        2,
        7,
    );
    assert_err(
        "@ <a> 0\nball x 1\n\x00\n",
        ErrorKind::ControlChar(0x00),
        3,
        1,
    );
    assert_err(
        "@ <a> 0\nball x 1\x7f\n",
        ErrorKind::ControlChar(0x7f),
        2,
        9,
    );
    assert_err("@ <a> 0\x1b\n", ErrorKind::ControlChar(0x1b), 1, 8);
}

// ---------------------------------------------------------------- whole-packet errors

#[test]
fn empty_datagram_is_rejected() {
    assert_err(b"", ErrorKind::Empty, 1, 1);
}

#[test]
fn non_utf8_is_rejected_at_the_first_bad_byte() {
    assert_err(b"@ <a> 0\nball x \xff\n", ErrorKind::NotUtf8, 2, 8);
    assert_err(b"\xfe@ <a> 0\n", ErrorKind::NotUtf8, 1, 1);
    assert_err(
        b"@ <a> 0\nball x 1\r\nnote t \"\xc3\x28\"\n",
        ErrorKind::NotUtf8,
        3,
        9,
    );
}

#[test]
fn truncated_multibyte_character_is_not_utf8() {
    let mut bytes = "@ <a> 0\nnote t é".as_bytes().to_vec();
    bytes.pop();
    assert_err(&bytes, ErrorKind::NotUtf8, 2, 8);
}

#[test]
fn utf8_check_comes_before_syntax() {
    assert_eq!(err(b"junk \xff").kind, ErrorKind::NotUtf8);
}

/// A valid packet of exactly `len` bytes: a header and one line padded with a string.
fn packet_of_len(len: usize) -> Vec<u8> {
    let head = "@ <a> 0\npad s \"";
    let tail = "\"\n";
    let fill = len - head.len() - tail.len();
    let mut text = String::with_capacity(len);
    text.push_str(head);
    text.extend(std::iter::repeat_n('x', fill));
    text.push_str(tail);
    assert_eq!(text.len(), len);
    text.into_bytes()
}

#[test]
fn packet_of_exactly_the_datagram_limit_is_accepted() {
    let bytes = packet_of_len(MAX_PACKET);
    let p = Packet::parse(&bytes).unwrap();
    assert_eq!(
        p.line("pad").unwrap().str("s").unwrap().len(),
        MAX_PACKET - 17
    );
}

#[test]
fn packet_one_byte_over_the_datagram_limit_is_rejected() {
    let bytes = packet_of_len(MAX_PACKET + 1);
    assert_err(&bytes, ErrorKind::TooLarge { len: 65_508 }, 1, 1);
}

#[test]
fn size_check_comes_before_everything_else() {
    let junk = vec![0xffu8; MAX_PACKET + 100];
    assert_eq!(
        err(&junk).kind,
        ErrorKind::TooLarge {
            len: MAX_PACKET + 100
        }
    );
}

#[test]
fn packet_at_the_limit_with_a_late_error_reports_that_error() {
    let mut bytes = packet_of_len(MAX_PACKET);
    let n = bytes.len();
    bytes[n - 2] = b'y'; // the closing quote becomes a letter
    assert_err(&bytes, ErrorKind::UnterminatedString, 2, 7);
}

#[test]
fn many_short_lines_up_to_the_limit_are_accepted() {
    let mut text = String::from("@ <a> 0\n");
    while text.len() + 6 <= MAX_PACKET {
        text.push_str("l x 1\n");
    }
    let p = parse(&text);
    let n = (MAX_PACKET - 8) / 6;
    assert_eq!(p.lines().count(), n);
    assert_eq!(p.lines().last().unwrap().number() as usize, n + 1);
}

/// Distinct names in shortlex order over the bare ASCII characters.
fn short_names() -> impl Iterator<Item = String> {
    let alphabet: Vec<char> = (0x21u8..0x7f)
        .filter(|b| !matches!(b, b'"' | b'(' | b')'))
        .map(char::from)
        .collect();
    (1usize..).flat_map(move |len| {
        let alphabet = alphabet.clone();
        let total = alphabet.len().pow(len as u32);
        (0..total).map(move |mut i| {
            let mut name = String::with_capacity(len);
            for _ in 0..len {
                name.push(alphabet[i % alphabet.len()]);
                i /= alphabet.len();
            }
            name
        })
    })
}

/// A single line of as many distinct names as a datagram holds, each with an
/// empty string as its value (`a""b""...`: three bytes a pair at best).
fn hostile_line(names: usize, duplicate_last: bool) -> (String, usize) {
    let mut text = String::from("@ <a> 0\nl ");
    let mut last = String::new();
    let mut dup_at = 0;
    for name in short_names().take(names) {
        text.push_str(&name);
        text.push_str("\"\"");
        last = name;
    }
    if duplicate_last {
        dup_at = text.len() - 8 + 1;
        text.push_str(&last);
        text.push_str("\"\"");
    }
    text.push('\n');
    (text, dup_at)
}

#[test]
fn hostile_line_with_thousands_of_distinct_names_parses() {
    // 20,000 distinct names cannot fit one datagram (three bytes a pair at best
    // for the first 91 names, four for the next 8,281, five after that), so this
    // is the widest line that fits: about 15,000 names.
    let mut names = 14_000;
    while hostile_line(names + 100, false).0.len() <= MAX_PACKET {
        names += 100;
    }
    let (text, _) = hostile_line(names, false);
    assert!(text.len() <= MAX_PACKET);
    let p = parse(&text);
    let line = p.line("l").unwrap();
    assert_eq!(line.fields().count(), names);
    assert!(line.fields().all(|f| f.value.as_str().unwrap().is_empty()));
}

#[test]
fn hostile_line_with_a_late_duplicate_is_rejected_at_it() {
    let (text, column) = hostile_line(12_000, true);
    assert!(text.len() <= MAX_PACKET);
    let e = err(&text);
    assert!(matches!(e.kind, ErrorKind::DuplicateName { .. }), "{e}");
    assert_eq!((e.line, e.column as usize), (2, column));
}

#[test]
fn line_with_twenty_thousand_distinct_names_is_too_large() {
    let (text, _) = hostile_line(20_000, false);
    assert_eq!(err(&text).kind, ErrorKind::TooLarge { len: text.len() });
}

// ---------------------------------------------------------------- error messages

#[test]
fn parse_error_display_names_line_column_and_problem() {
    let e = err("@ <a> 0\nball x 1 y 2 x 3\n");
    assert_eq!(
        e.to_string(),
        "line 2, column 14: duplicate name `x`: a name may appear once per line or group"
    );
    let e = err("@ <a> 0\nl g (x 1\n");
    assert_eq!(
        e.to_string(),
        "line 2, column 9: unbalanced parentheses: `(` not closed before the end of the line"
    );
    let e = err(b"");
    assert_eq!(
        e.to_string(),
        "line 1, column 1: empty packet: expected a header `@ <subject> priority`"
    );
    let e = err("@ <a> 0\nnote t \"\\q\"\n");
    assert_eq!(
        e.to_string(),
        "line 2, column 9: unknown escape `\\q` (known: \\\" \\\\ \\n \\r \\t)"
    );
    let e = err("@ <a> x\n");
    assert_eq!(
        e.to_string(),
        "line 1, column 7: priority `x` is not a 32-bit integer"
    );
    let e = err("@ <a> 0\nball\x07\n");
    assert_eq!(
        e.to_string(),
        "line 2, column 5: control character 0x07 is not allowed"
    );
}

#[test]
fn every_error_kind_has_a_message() {
    let kinds = [
        ErrorKind::TooLarge { len: 70_000 },
        ErrorKind::Empty,
        ErrorKind::NotUtf8,
        ErrorKind::BadHeader("x"),
        ErrorKind::BadSubject("a b".into()),
        ErrorKind::DuplicateSubject("a".into()),
        ErrorKind::BadPriority("p".into()),
        ErrorKind::ControlChar(1),
        ErrorKind::ExpectedLabel('('),
        ErrorKind::ExpectedName('"'),
        ErrorKind::MissingValue { name: "n".into() },
        ErrorKind::DuplicateName { name: "n".into() },
        ErrorKind::UnclosedGroup,
        ErrorKind::UnmatchedClose,
        ErrorKind::UnterminatedString,
        ErrorKind::BadEscape('q'),
        ErrorKind::TooDeep,
    ];
    let messages: Vec<String> = kinds.iter().map(|k| k.to_string()).collect();
    for (k, m) in kinds.iter().zip(&messages) {
        assert!(!m.is_empty(), "{k:?}");
    }
    let unique: std::collections::HashSet<_> = messages.iter().collect();
    assert_eq!(unique.len(), messages.len(), "messages tell kinds apart");
    assert!(messages[0].contains("70000") && messages[0].contains("65507"));
    assert!(messages[16].contains("32"));
}

// ---------------------------------------------------------------- typed getters

#[test]
fn f64_getter_reads_numbers_in_every_spelling() {
    let p = parse("@ <a> 0\nn a 1 b -2.5 c 1e3 d .5 e 5. f -0 g inf h NaN i 0.1\n");
    let n = p.line("n").unwrap();
    assert_eq!(n.f64("a").unwrap(), 1.0);
    assert_eq!(n.f64("b").unwrap(), -2.5);
    assert_eq!(n.f64("c").unwrap(), 1000.0);
    assert_eq!(n.f64("d").unwrap(), 0.5);
    assert_eq!(n.f64("e").unwrap(), 5.0);
    assert!(n.f64("f").unwrap().is_sign_negative());
    assert_eq!(n.f64("g").unwrap(), f64::INFINITY);
    assert!(n.f64("h").unwrap().is_nan());
    assert_eq!(n.f64("i").unwrap(), 0.1);
}

#[test]
fn f64_getter_on_a_word_names_label_field_line_and_column() {
    let p = parse("@ <a> 0\n\nball x fast y 1\n");
    let e = p.line("ball").unwrap().f64("x").unwrap_err();
    assert_eq!(
        e,
        FieldError {
            label: "ball".into(),
            field: "x".into(),
            line: 3,
            column: 8,
            kind: FieldErrorKind::NotANumber("fast".into()),
        }
    );
    assert_eq!(
        e.to_string(),
        "line 3, column 8: `ball` field `x`: `fast` is not a number"
    );
}

#[test]
fn f64_getter_on_a_quoted_number_is_not_a_number() {
    let p = parse("@ <a> 0\nball x \"5.3\"\n");
    let e = p.line("ball").unwrap().f64("x").unwrap_err();
    assert_eq!(e.kind, FieldErrorKind::NotANumber("\"5.3\"".into()));
    assert_eq!((e.line, e.column), (2, 8));
}

#[test]
fn f64_getter_on_a_group_is_not_a_number() {
    let p = parse("@ <a> 0\nball x (a 1)\n");
    let e = p.line("ball").unwrap().f64("x").unwrap_err();
    assert_eq!(e.kind, FieldErrorKind::NotANumber("( ... )".into()));
    assert_eq!(e.column, 8);
}

#[test]
fn i64_getter_reads_the_full_range() {
    let p = parse("@ <a> 0\nn min -9223372036854775808 max 9223372036854775807 plus +3\n");
    let n = p.line("n").unwrap();
    assert_eq!(n.i64("min").unwrap(), i64::MIN);
    assert_eq!(n.i64("max").unwrap(), i64::MAX);
    assert_eq!(n.i64("plus").unwrap(), 3);
}

#[test]
fn i64_getter_rejects_fractions_and_overflow_with_their_text() {
    let p = parse("@ <a> 0\nn frac 1.5 big 9223372036854775808 word x\n");
    let n = p.line("n").unwrap();
    let e = n.i64("frac").unwrap_err();
    assert_eq!(e.kind, FieldErrorKind::NotAnInteger("1.5".into()));
    assert_eq!(
        (e.label.as_str(), e.field.as_str(), e.line, e.column),
        ("n", "frac", 2, 8)
    );
    let e = n.i64("big").unwrap_err();
    assert_eq!(
        e.kind,
        FieldErrorKind::NotAnInteger("9223372036854775808".into())
    );
    assert_eq!(e.column, 16);
    assert_eq!(
        e.to_string(),
        "line 2, column 16: `n` field `big`: `9223372036854775808` is not a 64-bit integer"
    );
    let e = n.i64("word").unwrap_err();
    assert_eq!(e.column, 41);
}

#[test]
fn str_getter_gives_bare_tokens_as_written() {
    let p = parse("@ <a> 0\nn mode fast n 5.30\n");
    let n = p.line("n").unwrap();
    assert!(matches!(n.str("mode").unwrap(), Cow::Borrowed("fast")));
    assert_eq!(n.str("n").unwrap(), "5.30");
}

#[test]
fn str_getter_on_a_group_is_rejected() {
    let p = parse("@ <a> 0\nn g (a 1)\n");
    let e = p.line("n").unwrap().str("g").unwrap_err();
    assert_eq!(
        e,
        FieldError {
            label: "n".into(),
            field: "g".into(),
            line: 2,
            column: 5,
            kind: FieldErrorKind::NotAString,
        }
    );
    assert_eq!(
        e.to_string(),
        "line 2, column 5: `n` field `g`: expected a string, found a group"
    );
}

#[test]
fn group_getter_on_a_scalar_is_rejected() {
    let p = parse("@ <a> 0\nn g 1 h \"x\"\n");
    let n = p.line("n").unwrap();
    let e = n.group("g").unwrap_err();
    assert_eq!(
        (e.kind.clone(), e.line, e.column),
        (FieldErrorKind::NotAGroup, 2, 5)
    );
    assert_eq!(
        e.to_string(),
        "line 2, column 5: `n` field `g`: expected a group `( ... )`"
    );
    let e = n.group("h").unwrap_err();
    assert_eq!((e.kind, e.column), (FieldErrorKind::NotAGroup, 9));
}

#[test]
fn missing_field_points_at_the_lines_label() {
    let p = parse("@ <a> 0\nball x 1\n   blue x 2\n");
    let e = p.line("blue").unwrap().f64("y").unwrap_err();
    assert_eq!(
        e,
        FieldError {
            label: "blue".into(),
            field: "y".into(),
            line: 3,
            column: 4,
            kind: FieldErrorKind::Missing,
        }
    );
    assert_eq!(e.to_string(), "line 3, column 4: `blue` field `y`: missing");
    for e in [
        p.line("ball").unwrap().i64("q").unwrap_err(),
        p.line("ball").unwrap().str("q").unwrap_err(),
        p.line("ball").unwrap().group("q").unwrap_err(),
    ] {
        assert_eq!((e.kind, e.line, e.column), (FieldErrorKind::Missing, 2, 1));
    }
}

#[test]
fn missing_field_in_a_group_points_at_its_paren_and_names_the_group() {
    let p = parse("@ <a> 0\nblue id 0 pose (xh 1.0)\n");
    let pose = p.line("blue").unwrap().group("pose").unwrap();
    let e = pose.f64("yh").unwrap_err();
    assert_eq!(
        e,
        FieldError {
            label: "pose".into(),
            field: "yh".into(),
            line: 2,
            column: 16,
            kind: FieldErrorKind::Missing,
        }
    );
}

#[test]
fn group_getter_errors_point_at_the_value() {
    let p = parse("@ <a> 0\r\n\r\nblue pose (xh one yh (a 1))\r\n");
    let pose = p.line("blue").unwrap().group("pose").unwrap();
    let e = pose.f64("xh").unwrap_err();
    assert_eq!((e.line, e.column), (3, 15));
    assert_eq!(e.kind, FieldErrorKind::NotANumber("one".into()));
    let e = pose.i64("xh").unwrap_err();
    assert_eq!((e.line, e.column), (3, 15));
    let e = pose.str("yh").unwrap_err();
    assert_eq!((e.kind, e.column), (FieldErrorKind::NotAString, 22));
    let e = pose.group("xh").unwrap_err();
    assert_eq!((e.kind, e.column), (FieldErrorKind::NotAGroup, 15));
}

#[test]
fn getters_on_a_line_after_a_long_line_count_columns_from_their_own_line() {
    let long = format!(
        "l {}\n",
        (0..50)
            .map(|i| format!("k{i} {i}"))
            .collect::<Vec<_>>()
            .join(" ")
    );
    let text = format!("@ <a> 0\n{long}m x bad\n");
    let p = parse(&text);
    let e = p.line("m").unwrap().f64("x").unwrap_err();
    assert_eq!((e.line, e.column), (3, 5));
}

#[test]
fn value_accessors_agree_with_getters() {
    let p = parse("@ <a> 0\nl a 7 b \"s\" c (d 1)\n");
    let l = p.line("l").unwrap();
    let a = l.get("a").unwrap();
    assert_eq!(a.as_i64(), Some(7));
    assert_eq!(a.as_f64(), Some(7.0));
    assert_eq!(a.as_str().unwrap(), "7");
    assert!(a.as_group().is_none());
    let b = l.get("b").unwrap();
    assert_eq!(b.as_i64(), None);
    assert_eq!(b.as_f64(), None);
    assert_eq!(b.as_str().unwrap(), "s");
    let c = l.get("c").unwrap();
    assert!(c.as_str().is_none());
    assert_eq!(c.as_group().unwrap().i64("d").unwrap(), 1);
}

// ---------------------------------------------------------------- Display

#[test]
fn display_writes_a_canonical_packet_back_byte_for_byte() {
    for text in [
        VISION,
        "@ <a> 0\n",
        "@ <task> <robot:7> -3\nannounce id 9 need (arm 1 cam 2) note \"a \\\"b\\\" \\\\ \\n\"\nstatus\n",
        "@ <a> 2147483647\nl g () h (a (b (c 1))) s \"\" t \"(x)\"\n",
    ] {
        assert_eq!(parse(text).to_string(), text);
    }
    let deep = nested(MAX_DEPTH);
    assert_eq!(parse(&deep).to_string(), deep);
}

#[test]
fn display_canonicalises_blanks_line_ends_priority_and_blank_lines() {
    let p =
        parse("@\t<a>   <b>\t+5  \r\n\r\n  ball \t x 5.3   y\t-2.5 \r\n\n l g(  k 1 )z\"q\" \n");
    let canon = "@ <a> <b> 5\nball x 5.3 y -2.5\nl g (k 1) z \"q\"\n";
    assert_eq!(p.to_string(), canon);
    assert_eq!(parse(canon).to_string(), canon);
}

#[test]
fn debug_of_a_packet_shows_its_text() {
    let p = parse("@ <a> 0\nl x 1\n");
    assert_eq!(format!("{p:?}"), r#"Packet { text: "@ <a> 0\nl x 1\n" }"#);
    let l = p.line("l").unwrap();
    assert_eq!(format!("{l:?}"), r#"Line { label: "l", number: 2 }"#);
}

#[test]
fn a_line_reads_back_as_written_without_its_blanks_or_line_end() {
    let p = Packet::parse(b"@ <a> 0\n  cmd id 3  vl 0.5 note \"x y\"  \r\nlone\n\n last g (a 1)")
        .unwrap();
    let texts: Vec<&str> = p.lines().map(|l| l.as_str()).collect();
    assert_eq!(
        texts,
        ["cmd id 3  vl 0.5 note \"x y\"", "lone", "last g (a 1)"]
    );
}
