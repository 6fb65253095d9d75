//! Drawing the spy with ratatui: the channel table, or one channel decoded field by field with
//! a plot of the chosen field, between a title line and a status line and the keys' help.
//! Everything fits 80 columns and 24 lines (more rows show on a taller terminal), uses only
//! reverse video and bold for emphasis, so it reads the same over SSH on any terminal.

use std::time::Duration;

use colony_wire::Packet;
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Modifier, Style};
use ratatui::symbols::Marker;
use ratatui::text::{Line, Span};
use ratatui::widgets::{
    Axis, Block, Borders, Cell, Chart, Dataset, GraphType, Paragraph, Row, Table, TableState, Wrap,
};
use ratatui::Frame;

use super::fields::{self, printable};
use super::model::{Feed, HubLink, LogState, Spy, Tap};

/// Lines the plot takes, its frame included.
const PLOT_HEIGHT: u16 = 9;
/// Characters of the filter the status line shows at most.
const FILTER_SHOWN: usize = 24;

/// Lines for an alert of `text` on a screen of `area`: enough for it wrapped at words (a
/// word-wrapped line loses at most a word's width, so a line's worth of slack per five), at
/// least 3, and at most half the screen.
fn alert_height(text: &str, area: Rect) -> u16 {
    let width = usize::from(area.width.max(1));
    let lines = text.chars().count().div_ceil(width);
    let lines = (lines + lines.div_ceil(5)).max(3);
    u16::try_from(lines)
        .unwrap_or(u16::MAX)
        .min((area.height / 2).max(3))
}

/// Draws the whole screen: the view as frozen, if it is.
pub fn draw(frame: &mut Frame<'_>, spy: &Spy) {
    let spy = spy.shown();
    // What went wrong is shown whole, wrapped, above the status line.
    let alert = match &spy.feed {
        Feed::Hub {
            state: HubLink::Failing(why),
            ..
        }
        | Feed::Log {
            state: LogState::Failed(why) | LogState::Ended(Some(why)),
            ..
        } => Some(printable(why)),
        _ => None,
    };
    let [title, body, alert_area, status, help] = Layout::vertical([
        Constraint::Length(1),
        Constraint::Min(3),
        Constraint::Length(
            alert
                .as_deref()
                .map_or(0, |why| alert_height(why, frame.area())),
        ),
        Constraint::Length(1),
        Constraint::Length(1),
    ])
    .areas(frame.area());
    if let Some(why) = alert {
        frame.render_widget(
            Paragraph::new(why)
                .wrap(Wrap { trim: true })
                .style(Style::new().add_modifier(Modifier::BOLD)),
            alert_area,
        );
    }
    frame.render_widget(
        Paragraph::new(title_line(spy)).style(Style::new().add_modifier(Modifier::REVERSED)),
        title,
    );
    if spy.open().is_some() {
        draw_channel(frame, body, spy);
    } else {
        draw_table(frame, body, spy);
    }
    frame.render_widget(Paragraph::new(status_line(spy)), status);
    frame.render_widget(
        Paragraph::new(help_line(spy)).style(Style::new().add_modifier(Modifier::DIM)),
        help,
    );
}

fn title_line(spy: &Spy) -> Line<'static> {
    let window = format!("window {}", seconds(spy.window()));
    let text = match &spy.feed {
        Feed::Hub { addr, state } => {
            let state = match state {
                HubLink::Waiting => "waiting".to_string(),
                HubLink::Alive => "alive".to_string(),
                HubLink::Unreachable { silent_for } => {
                    format!("UNREACHABLE ({} silent)", seconds(*silent_for))
                }
                HubLink::Failing(_) => "FAILING (below)".to_string(),
            };
            let tap = match spy.tap() {
                Tap::Unknown => "",
                Tap::Tapping => " tapping",
                Tap::Refused => " TAP REFUSED (too many taps; try --key)",
            };
            let frozen = if spy.paused() {
                "  FROZEN (still counting)"
            } else {
                ""
            };
            format!(" colony spy  hub {addr} {state}{tap}{frozen}  {window}")
        }
        Feed::Log { file, speed, state } => {
            let state = match (state, spy.seeking()) {
                (LogState::Playing, Some(to)) => format!("seeking +{:.1} s", to.as_secs_f64()),
                (LogState::Playing, None) if spy.paused() => String::new(),
                (LogState::Playing, None) => "playing".to_string(),
                (LogState::Ended(_), _) => "ended".to_string(),
                (LogState::Failed(_), _) => "STOPPED (below)".to_string(),
            };
            let paused = match (spy.paused(), state.is_empty()) {
                (true, true) => "PAUSED",
                (true, false) => " PAUSED",
                (false, _) => "",
            };
            format!(" colony spy  log {file} x{speed} {state}{paused}  {window}")
        }
    };
    Line::from(text)
}

/// The log's time, the counts, and the filter with how many channels it lets through; while
/// a filter is typed, that alone.
fn status_line(spy: &Spy) -> Line<'static> {
    let (filter, typing) = spy.filter();
    let matching = format!("{} of {}", spy.listed_count(), spy.channel_count());
    if typing {
        // The end of a long filter, where the typing is.
        let chars = filter.chars().count();
        let tail: String = filter
            .chars()
            .skip(chars.saturating_sub(FILTER_SHOWN))
            .collect();
        return Line::from(vec![
            Span::raw(" /"),
            Span::styled(
                format!("{}_", printable(&tail)),
                Style::new().add_modifier(Modifier::BOLD),
            ),
            Span::raw(format!("  {matching} channels match")),
        ]);
    }
    let mut text = String::new();
    if matches!(spy.feed, Feed::Log { .. }) {
        text.push_str(&format!(" log +{:.1} s ", spy.now().as_secs_f64()));
    }
    text.push_str(&format!(" seen {}", spy.seen()));
    if matches!(spy.feed, Feed::Hub { .. }) {
        text.push_str(&format!("  missed {}", spy.missed()));
    }
    text.push_str(&format!("  unparsed {}", spy.unparsed()));
    if spy.over_cap() > 0 {
        text.push_str(&format!("  {} past the channel cap", spy.over_cap()));
    }
    let mut line = vec![Span::raw(text)];
    if !filter.is_empty() {
        let mut shown: String = filter.chars().take(FILTER_SHOWN).collect();
        if shown.len() < filter.len() {
            shown.push_str("...");
        }
        line.push(Span::styled(
            format!("  /{}: {matching}", printable(&shown)),
            Style::new().add_modifier(Modifier::BOLD),
        ));
    }
    Line::from(line)
}

/// The keys that do something here.
fn help_line(spy: &Spy) -> String {
    let log = matches!(spy.feed, Feed::Log { .. });
    let (filter, typing) = spy.filter();
    if typing {
        return " type a filter of the channels  Enter keep  Esc clear  Backspace erase".into();
    }
    let space = match (log, spy.paused()) {
        (_, true) => "space resume",
        (true, false) => "space pause",
        (false, false) => "space freeze",
    };
    let seek = if log {
        "  ←→ 10 s  Home restart"
    } else {
        ""
    };
    if spy.open().is_some() {
        let field = if log {
            "Tab/↑↓ field"
        } else {
            "Tab/arrows field"
        };
        format!(" {field}  / filter  {space}{seek}  Esc back")
    } else {
        let back = if filter.is_empty() {
            "q quit"
        } else {
            "Esc clear"
        };
        format!(" ↑↓ select  Enter open  / filter  {space}{seek}  {back}")
    }
}

fn draw_table(frame: &mut Frame<'_>, area: Rect, spy: &Spy) {
    let now = spy.now();
    let header = Row::new(["channel", "rate/s", "B/s", "priority", "age", "last packet"])
        .style(Style::new().add_modifier(Modifier::BOLD));
    let rows = spy.listed().map(|(name, c)| {
        let (rate, bandwidth) = match c.rates(now) {
            Some((r, b)) => (rate_text(r), bytes_text(b)),
            None => ("-".into(), "-".into()),
        };
        let age = c
            .last_at
            .map_or(String::new(), |t| age_text(now.saturating_sub(t)));
        Row::new([
            Cell::from(name.clone()),
            Cell::from(Line::from(rate).right_aligned()),
            Cell::from(Line::from(bandwidth).right_aligned()),
            Cell::from(c.priorities.summary()),
            Cell::from(Line::from(age).right_aligned()),
            Cell::from(printable(c.preview())),
        ])
    });
    let widths = [
        Constraint::Length(20),
        Constraint::Length(8),
        Constraint::Length(7),
        Constraint::Length(10),
        Constraint::Length(5),
        Constraint::Fill(1),
    ];
    let table = Table::new(rows, widths)
        .header(header)
        .row_highlight_style(Style::new().add_modifier(Modifier::REVERSED));
    let mut state = TableState::default().with_selected(spy.selected().map(|(i, _)| i));
    if spy.listed_count() == 0 {
        let waiting = match &spy.feed {
            _ if spy.channel_count() > 0 => "no channel matches the filter (Esc clears it)",
            Feed::Hub { .. } => "no packets yet: waiting for traffic on the hub",
            Feed::Log { .. } => "no packets yet",
        };
        let [head, rest] =
            Layout::vertical([Constraint::Length(2), Constraint::Min(0)]).areas(area);
        frame.render_stateful_widget(table, head, &mut state);
        frame.render_widget(Paragraph::new(format!(" {waiting}")), rest);
        return;
    }
    frame.render_stateful_widget(table, area, &mut state);
}

fn draw_channel(frame: &mut Frame<'_>, area: Rect, spy: &Spy) {
    let Some(open) = spy.open() else { return };
    let now = spy.now();
    let [info, list, plot] = Layout::vertical([
        Constraint::Length(1),
        Constraint::Min(2),
        Constraint::Length(PLOT_HEIGHT),
    ])
    .areas(area);
    let c = spy.channel(&open.name);
    let mut head = format!(" {}", open.name);
    if let Some(c) = c {
        if let Some((r, b)) = c.rates(now) {
            head.push_str(&format!("  {}/s  {}B/s", rate_text(r), bytes_text(b)));
        }
        head.push_str(&format!(
            "  priority {}  {} packets  last {} B",
            c.priorities.summary(),
            c.packets,
            c.last_len
        ));
        if let Some(t) = c.last_at {
            head.push_str(&format!(" {} ago", age_text(now.saturating_sub(t))));
        }
    }
    frame.render_widget(
        Paragraph::new(head).style(Style::new().add_modifier(Modifier::BOLD)),
        info,
    );

    let text = c.map_or("", |c| c.last.as_str());
    let (rows, left_off) = match Packet::parse(text.as_bytes()) {
        Ok(p) => fields::rows(&p),
        Err(_) => (Vec::new(), 0),
    };
    let chosen = open.field.as_deref();
    let selected = rows.iter().position(|r| Some(r.key.as_str()) == chosen);
    let height = list.height.saturating_sub(1) as usize;
    let mut body: Vec<Row> = rows
        .iter()
        .map(|r| {
            let style = if r.number.is_some() {
                Style::new()
            } else {
                Style::new().add_modifier(Modifier::DIM)
            };
            Row::new([Cell::from(r.shown.clone()), Cell::from(r.value.clone())]).style(style)
        })
        .collect();
    if left_off > 0 {
        body.push(Row::new([
            format!("... {left_off} more fields"),
            String::new(),
        ]));
    }
    if rows.is_empty() && c.is_some_and(|c| !c.last_whole()) {
        body.push(Row::new([
            "(the last packet was too long to keep: waiting for the next)".to_string(),
            String::new(),
        ]));
    }
    let table = Table::new(body, [Constraint::Percentage(55), Constraint::Fill(1)])
        .header(Row::new(["field", "value"]).style(Style::new().add_modifier(Modifier::BOLD)))
        .row_highlight_style(Style::new().add_modifier(Modifier::REVERSED));
    // The chosen field sits mid-list where it can.
    let offset = selected.map_or(0, |s| {
        s.saturating_sub(height / 2)
            .min(rows.len().saturating_sub(height))
    });
    let mut state = TableState::default()
        .with_offset(offset)
        .with_selected(selected);
    frame.render_stateful_widget(table, list, &mut state);

    let shown = selected.map(|i| rows[i].shown.as_str()).or(chosen);
    draw_plot(
        frame,
        plot,
        spy,
        chosen.is_some().then_some(shown).flatten(),
    );
}

/// Plots the chosen field (`shown`: its path as the list shows it).
fn draw_plot(frame: &mut Frame<'_>, area: Rect, spy: &Spy, shown: Option<&str>) {
    let block = Block::new().borders(Borders::TOP);
    let points: Vec<(f64, f64)> = spy
        .open()
        .and_then(|o| o.series())
        .map(|s| s.iter().copied().collect())
        .unwrap_or_default();
    let Some(shown) = shown else {
        frame.render_widget(
            Paragraph::new(" no numeric field to plot in this channel's last packet").block(block),
            area,
        );
        return;
    };
    let Some(&(_, last)) = points.last() else {
        frame.render_widget(
            Paragraph::new(format!(" {shown}: no values yet")).block(block),
            area,
        );
        return;
    };
    let now = spy.now().as_secs_f64();
    let (lo, hi) = points
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &(_, v)| {
            (lo.min(v), hi.max(v))
        });
    let title = format!(
        " {shown}  now {}  min {}  max {}  ({} points) ",
        number_text(last),
        number_text(lo),
        number_text(hi),
        points.len()
    );
    let block = block.title(title);
    // Values so far apart that their difference overflows cannot share a scale.
    if !(hi - lo).is_finite() {
        frame.render_widget(
            Paragraph::new(" values too far apart to plot on one scale").block(block),
            area,
        );
        return;
    }
    let (lo, hi) = if hi > lo {
        (lo, hi)
    } else {
        (lo - 1.0, hi + 1.0)
    };
    let oldest = points.first().map_or(now, |p| p.0);
    let span = (now - oldest).max(1.0);
    let relative: Vec<(f64, f64)> = points.iter().map(|&(t, v)| (t - now, v)).collect();
    let chart = Chart::new(vec![Dataset::default()
        .marker(Marker::Braille)
        .graph_type(GraphType::Line)
        .data(&relative)])
    .block(block)
    .x_axis(Axis::default().bounds([-span, 0.0]).labels([
        format!("-{}", seconds(Duration::from_secs_f64(span))),
        "now".to_string(),
    ]))
    .y_axis(
        Axis::default()
            .bounds([lo, hi])
            .labels([number_text(lo), number_text(hi)]),
    );
    frame.render_widget(chart, area);
}

/// Packets per second: two decimals below 10 (a channel at 0.4/s reads to within 2 %).
pub fn rate_text(r: f64) -> String {
    if r < 10.0 {
        format!("{r:.2}")
    } else if r < 1000.0 {
        format!("{r:.1}")
    } else {
        format!("{r:.0}")
    }
}

/// Bytes per second with a decimal prefix.
pub fn bytes_text(b: f64) -> String {
    if b < 1000.0 {
        format!("{b:.0}")
    } else if b < 1e6 {
        format!("{:.1}k", b / 1e3)
    } else if b < 1e9 {
        format!("{:.1}M", b / 1e6)
    } else {
        format!("{:.1}G", b / 1e9)
    }
}

fn age_text(d: Duration) -> String {
    let s = d.as_secs_f64();
    if s < 10.0 {
        format!("{s:.1}s")
    } else if s < 600.0 {
        format!("{s:.0}s")
    } else if s < 36_000.0 {
        format!("{:.0}m", s / 60.0)
    } else {
        format!("{:.0}h", s / 3600.0)
    }
}

fn seconds(d: Duration) -> String {
    let s = d.as_secs_f64();
    if s < 10.0 && s.fract() != 0.0 {
        format!("{s:.1} s")
    } else {
        format!("{s:.0} s")
    }
}

/// A number short enough for an axis label: up to 6 significant digits, exponent beyond.
fn number_text(v: f64) -> String {
    let a = v.abs();
    if a != 0.0 && !(1e-3..1e7).contains(&a) {
        format!("{v:.3e}")
    } else {
        let s = format!("{v:.4}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        s.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmd::spy::model::Key;
    use ratatui::backend::TestBackend;
    use ratatui::Terminal;

    fn screen(spy: &Spy) -> Vec<String> {
        let mut t = Terminal::new(TestBackend::new(80, 24)).unwrap();
        t.draw(|f| draw(f, spy)).unwrap();
        let buf = t.backend().buffer().clone();
        (0..24)
            .map(|y| (0..80).map(|x| buf[(x, y)].symbol()).collect::<String>())
            .collect()
    }

    fn demo() -> Spy {
        let mut s = Spy::new(
            Feed::Hub {
                addr: "127.0.0.1:7400".into(),
                state: HubLink::Alive,
            },
            Duration::from_secs(1),
        );
        for i in 0..100u32 {
            let t = Duration::from_millis(u64::from(i) * 50);
            let vision = format!(
                "@ <vision> 0\nrobot id 0 x {} y 2.5 pose (th 0.1)\nrobot id 1 x 3 y 4\npuck x 1 y 1\n",
                f64::from(i) / 10.0
            );
            s.on_datagram(t, vision.as_bytes());
            if i % 5 == 0 {
                s.on_datagram(t, b"@ <metrics> 10\nprogress step 12 pc 0.5\n");
            }
        }
        s.set_now(Duration::from_secs(5));
        s
    }

    #[test]
    fn the_table_fits_80_columns_with_every_channel_its_rate_and_the_status_line() {
        let s = demo();
        let lines = screen(&s);
        assert!(lines[0].contains("hub 127.0.0.1:7400 alive"), "{lines:#?}");
        assert!(lines[1].starts_with("channel"), "{lines:#?}");
        let vision = lines.iter().find(|l| l.starts_with("vision")).unwrap();
        assert!(
            vision.contains("19.0") || vision.contains("20.0"),
            "{vision}"
        );
        assert!(vision.contains("robot id 0 x 9.9"), "{vision}");
        let metrics = lines.iter().find(|l| l.starts_with("metrics")).unwrap();
        assert!(metrics.contains("4.00"), "{metrics}");
        assert!(metrics.contains(" 10 "), "{metrics}");
        assert!(
            lines[22].starts_with(" seen 120  missed 0  unparsed 0"),
            "{lines:#?}"
        );
        assert!(lines[23].contains("/ filter  space freeze"), "{lines:#?}");
        // A failing socket says why, with what it said made safe to print.
        let mut s = s;
        s.feed = Feed::Hub {
            addr: "10.0.0.9:7400".into(),
            state: HubLink::Failing("Network is unreachable\u{1b}[2J".into()),
        };
        let lines = screen(&s);
        assert!(
            lines[0].contains("10.0.0.9:7400 FAILING (below)"),
            "{lines:#?}"
        );
        assert!(
            lines[19].starts_with("Network is unreachable\\u{1b}[2J"),
            "{lines:#?}"
        );
        // A log that cannot be read further says why, whole.
        let why = format!(
            "/a/long/path/{}/t.clog: record at byte 1234 is corrupt (checksum)",
            "x".repeat(60)
        );
        s.feed = Feed::Log {
            file: "t.clog".into(),
            speed: 1.0,
            state: LogState::Failed(why),
        };
        let lines = screen(&s);
        assert!(lines[0].contains("STOPPED (below)"), "{lines:#?}");
        let text: String = lines[19..22].join(" ");
        assert!(text.contains("is corrupt (checksum)"), "{lines:#?}");
        // A log played to its end says what a crash cut short of it.
        s.feed = Feed::Log {
            file: "t.mcap".into(),
            speed: 1.0,
            state: LogState::Ended(Some("t.mcap ends before its writer finished it".into())),
        };
        let lines = screen(&s);
        assert!(lines[0].contains("ended"), "{lines:#?}");
        let text: String = lines[19..22].join(" ");
        assert!(text.contains("before its writer finished it"), "{lines:#?}");
        // A long note is shown whole, to its last word.
        let note = format!(
            "/tmp/a/long/path/traffic.mcap ends before its writer finished it (no summary: the \
             writer was stopped, or is still writing): read 1234 messages from 56 whole chunks; \
             the 7890 bytes from byte 123456 on (a chunk cut short, if any) were not read. If \
             its writer is gone, `colony log recover /tmp/a/long/path/traffic.mcap OUT.mcap` \
             rewrites it as a {}",
            "valid MCAP"
        );
        s.feed = Feed::Log {
            file: "traffic.mcap".into(),
            speed: 1.0,
            state: LogState::Ended(Some(note)),
        };
        let text = screen(&s).join(" ");
        assert!(text.contains("valid MCAP"), "{text}");
    }

    #[test]
    fn an_open_channel_lists_its_fields_and_plots_the_chosen_one() {
        let mut s = demo();
        s.on_key(Key::Down);
        s.on_key(Key::Open);
        // New packets feed the plot.
        for i in 0..10u32 {
            let text = format!("@ <vision> 0\nrobot id 0 x {i} y 2.5\nrobot id 1 x 3 y 4\n");
            s.on_datagram(
                Duration::from_millis(5000 + u64::from(i) * 100),
                text.as_bytes(),
            );
        }
        s.on_key(Key::Next);
        let lines = screen(&s);
        let text = lines.join("\n");
        assert!(lines[1].starts_with(" vision"), "{text}");
        assert!(text.contains("robot[0].x"), "{text}");
        assert!(text.contains("robot[1].y"), "{text}");
        assert!(text.contains("robot[0].x  now 9  min 0  max 9"), "{text}");
        assert!(lines[23].contains("Esc back"), "{text}");
        assert!(lines.iter().all(|l| l.chars().count() == 80));
    }

    #[test]
    fn a_filter_lists_only_the_channels_it_matches_and_says_how_many() {
        let mut s = demo();
        s.on_datagram(Duration::from_secs(5), b"@ <camera.0> 0\nblob x 1\n");
        s.on_key(Key::Search);
        for c in "pro".chars() {
            s.on_key(Key::Char(c));
        }
        // While typed: the filter with a cursor, and what it matches (metrics, by its last
        // packet's `progress`).
        let lines = screen(&s);
        assert!(
            lines[22].starts_with(" /pro_  1 of 3 channels match"),
            "{lines:#?}"
        );
        assert!(lines[23].contains("Enter keep  Esc clear"), "{lines:#?}");
        let listed: Vec<&String> = lines[2..21]
            .iter()
            .filter(|l| !l.trim().is_empty())
            .collect();
        assert_eq!(listed.len(), 1, "{lines:#?}");
        assert!(listed[0].starts_with("metrics"), "{lines:#?}");
        // Kept: on the status line after the counts.
        s.on_key(Key::Erase);
        s.on_key(Key::Erase);
        s.on_key(Key::Open);
        let lines = screen(&s);
        // (`p` is in vision's `pose` too.)
        assert!(
            lines[22].starts_with(" seen 121  missed 0  unparsed 0  /p: 2 of 3"),
            "{lines:#?}"
        );
        assert!(lines[3].starts_with("vision"), "{lines:#?}");
        assert!(lines[23].trim_end().ends_with("Esc clear"), "{lines:#?}");
        // A filter nothing matches says so.
        s.on_key(Key::Search);
        s.on_key(Key::Char('#'));
        let text = screen(&s).join("\n");
        assert!(text.contains("no channel matches the filter"), "{text}");
    }

    #[test]
    fn a_paused_log_and_a_frozen_hub_say_so() {
        let mut s = demo();
        s.feed = Feed::Log {
            file: "t.clog".into(),
            speed: 2.0,
            state: LogState::Playing,
        };
        let lines = screen(&s);
        assert!(lines[0].contains("log t.clog x2 playing"), "{lines:#?}");
        assert!(lines[22].starts_with(" log +5.0 s  seen 120"), "{lines:#?}");
        assert!(
            lines[23].contains("space pause  ←→ 10 s  Home restart"),
            "{lines:#?}"
        );
        assert!(lines.iter().all(|l| l.chars().count() == 80));
        s.on_key(Key::Pause);
        let lines = screen(&s);
        assert!(lines[0].contains("log t.clog x2 PAUSED"), "{lines:#?}");
        assert!(lines[23].contains("space resume"), "{lines:#?}");
        s.set_seeking(Some(Duration::from_secs(15)));
        assert!(screen(&s)[0].contains("x2 seeking +15.0 s PAUSED"));

        // A frozen hub: the screen stays as it was while the spy counts on.
        let mut s = demo();
        s.on_key(Key::Pause);
        let before = screen(&s);
        assert!(
            before[0].contains("alive  FROZEN (still counting)"),
            "{before:#?}"
        );
        for i in 0..50u64 {
            s.on_datagram(Duration::from_millis(5000 + i * 10), b"@ <new> 0\nx n 1\n");
        }
        s.set_now(Duration::from_secs(9));
        assert_eq!(screen(&s), before);
        assert_eq!(s.seen(), 170);
        s.on_key(Key::Pause);
        let after = screen(&s).join("\n");
        assert!(
            after.contains("seen 170") && after.contains("new "),
            "{after}"
        );
        assert!(!after.contains("FROZEN"), "{after}");
    }

    #[test]
    fn any_terminal_size_draws_without_a_panic() {
        let mut s = demo();
        s.on_datagram(
            Duration::from_secs(5),
            b"@ <wide> 0\nv a 1e308 b -1e308 c 2\nv a -1e308\n",
        );
        for open in [false, true] {
            if open {
                s.on_key(Key::End);
                s.on_key(Key::Open);
                s.on_datagram(Duration::from_secs(6), b"@ <wide> 0\nv a -1e308\n");
            }
            for (w, h) in [(1, 1), (10, 3), (20, 5), (80, 24), (200, 60), (80, 2)] {
                let mut t = Terminal::new(TestBackend::new(w, h)).unwrap();
                t.draw(|f| draw(f, &s)).unwrap();
            }
        }
        let text = screen(&s).join("\n");
        assert!(text.contains("too far apart"), "{text}");
    }

    #[test]
    fn numbers_are_short_enough_for_the_columns() {
        assert_eq!(rate_text(0.4), "0.40");
        assert_eq!(rate_text(18.44), "18.4");
        assert_eq!(rate_text(123_456.0), "123456");
        assert_eq!(bytes_text(16_018.0), "16.0k");
        assert_eq!(number_text(1e308), "1.000e308");
        assert_eq!(number_text(2.5), "2.5");
        assert_eq!(number_text(0.0), "0");
    }
}
