//! `colony pub` and `colony sub`.

use std::io::{Read as _, Write as _};
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use anyhow::Context as _;
use colony_client::HubState;
use colony_wire::{
    parse_subject_set, split_blocks, starts_with_packet, BlockWriter, Packet, PacketBuilder,
    Priority, Subject,
};

use super::HubAddr;

#[derive(clap::Args, Debug)]
pub struct PubArgs {
    #[command(flatten)]
    pub hub: HubAddr,
    /// The packet's priority (default 0).
    #[arg(long, short, allow_negative_numbers = true)]
    pub priority: Option<i32>,
    /// Where the packet goes: a channel (`radio`), or a subject set,
    /// comma-separated (`mobile,camera`) or as a header writes it
    /// (`'<mobile> <camera>'`). Left out, standard input holds whole packets.
    #[arg(value_name = "SUBJECTS")]
    pub subjects: Option<String>,
    /// The packet's body, a line per argument: `colony pub radio 'cmd id 3 vl 0.2'
    /// stop`. With none, the body is read from standard input, unless that
    /// starts with a header (`@`): then it holds whole packets, each ended by a
    /// blank line, as `colony sub` prints them.
    #[arg(value_name = "LINE")]
    pub lines: Vec<String>,
}

#[derive(clap::Args, Debug)]
pub struct SubArgs {
    #[command(flatten)]
    pub hub: HubAddr,
    /// Stop after this many packets.
    #[arg(long, short = 'n')]
    pub count: Option<u64>,
    /// Print each packet as it came, not with the characters that could act on
    /// a terminal (C1 controls, marks that reorder text) shown as `\u{9b}`.
    #[arg(long)]
    pub raw: bool,
    /// Print each packet as one line of JSON instead (its exact text, header and
    /// lines as data: the schema MCAP logs and Foxglove use), for programs.
    #[arg(long, conflicts_with = "raw")]
    pub json: bool,
    /// Subjects to subscribe to; each packet to any of them is printed, a blank
    /// line between packets (`colony pub` reads them back).
    #[arg(required = true, value_name = "SUBJECT")]
    pub subjects: Vec<String>,
}

/// The subject set `pub` was given, as one argument.
fn parse_subjects(text: &str) -> anyhow::Result<Vec<Subject>> {
    parse_subject_set(text).map_err(|e| {
        anyhow::anyhow!(
            "{e} (`colony pub SUBJECTS LINE...`: the subjects are the first argument, each \
             argument after it a line of the body)"
        )
    })
}

fn build(subjects: &[Subject], priority: i32, lines: &[&str]) -> anyhow::Result<Vec<u8>> {
    let mut b = PacketBuilder::new(subjects, Priority(priority));
    for l in lines.iter().flat_map(|l| l.lines()) {
        b.raw_line(l);
    }
    b.finish()
        .context("malformed packet (the header counts as line 1)")
}

/// The whole packets on standard input; each must go to `subjects` when given.
fn packets_in(text: &str, subjects: Option<&[Subject]>) -> anyhow::Result<Vec<Vec<u8>>> {
    let blocks = split_blocks(text).context("standard input")?;
    let mut packets = Vec::with_capacity(blocks.len());
    for (i, block) in blocks.iter().enumerate() {
        let what = || format!("packet {} (line {}) on standard input", i + 1, block.line);
        let p = Packet::parse(block.text.as_bytes()).with_context(what)?;
        if let Some(wanted) = subjects {
            let mut got: Vec<&str> = p.subjects().collect();
            let mut want: Vec<&str> = wanted.iter().map(Subject::as_str).collect();
            got.sort_unstable();
            want.sort_unstable();
            if got != want {
                anyhow::bail!(
                    "{} goes to <{}>, not to the <{}> given (leave the subjects out to publish \
                     each packet where its header says)",
                    what(),
                    got.join("> <"),
                    want.join("> <")
                );
            }
        }
        packets.push(block.text.as_bytes().to_vec());
    }
    if packets.is_empty() {
        anyhow::bail!("no packet on standard input");
    }
    Ok(packets)
}

pub fn publish(args: PubArgs) -> anyhow::Result<()> {
    let subjects = args.subjects.as_deref().map(parse_subjects).transpose()?;
    let packets = if !args.lines.is_empty() {
        let lines: Vec<&str> = args.lines.iter().map(String::as_str).collect();
        let subjects = subjects.context("give the subjects before the lines")?;
        vec![build(&subjects, args.priority.unwrap_or(0), &lines)?]
    } else {
        let mut text = String::new();
        std::io::stdin()
            .read_to_string(&mut text)
            .context("cannot read packets from standard input")?;
        if starts_with_packet(&text) {
            if args.priority.is_some() {
                anyhow::bail!(
                    "standard input holds whole packets, each with its own priority: leave out --priority"
                );
            }
            packets_in(&text, subjects.as_deref())?
        } else {
            let subjects = subjects.context(
                "give the subjects (`colony pub radio`), or whole packets on standard input",
            )?;
            vec![build(
                &subjects,
                args.priority.unwrap_or(0),
                &[text.as_str()],
            )?]
        }
    };
    let mut client = args.hub.connect()?;
    // The hub answers no publisher: asking it first is how `pub` can tell the
    // user that nobody is there, or that the hub drops what is not signed
    // with its key, instead of exiting 0 with the packets lost.
    colony_client::status::fetch_status_with(&mut client, HUB_ANSWER)
        .context("the packets were not sent")?;
    for p in &packets {
        client.publish(p)?;
    }
    Ok(())
}

/// JSON with every character that could act on a terminal written as a
/// `\uXXXX` escape: JSON leaves C1 controls and bidirectional marks as they
/// are, and a program reading the line gets the same text either way.
fn json_for_terminal(json: &[u8]) -> String {
    let text = String::from_utf8_lossy(json);
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        if colony_wire::is_unsafe_for_terminal(c) {
            let mut units = [0u16; 2];
            for u in c.encode_utf16(&mut units) {
                out.push_str(&format!("\\u{u:04x}"));
            }
        } else {
            out.push(c);
        }
    }
    out
}

/// How long `pub` waits for the hub to answer before it publishes.
const HUB_ANSWER: Duration = Duration::from_secs(3);

/// How long `sub` waits for a first answer before it says none came.
const FIRST_ANSWER: Duration = Duration::from_secs(3);

pub fn subscribe(args: SubArgs) -> anyhow::Result<()> {
    let mut client = args.hub.connect()?;
    for s in &args.subjects {
        client.subscribe(s)?;
    }
    let stop = super::stop_flag()?;
    let stdout = std::io::stdout();
    let mut seen = 0u64;
    let mut blocks = BlockWriter::new();
    let mut warned = false;
    let started = Instant::now();
    'run: while !stop.load(Ordering::Relaxed) {
        let wake = client
            .next_deadline()
            .map(|d| d.min(Instant::now() + Duration::from_millis(250)));
        client.wait(wake)?;
        client.poll(Instant::now())?;
        let mut out = stdout.lock();
        while let Some(packet) = client.recv()? {
            if args.json {
                let mut line = json_for_terminal(&colony_schema::to_json(&packet, None));
                line.push('\n');
                out.write_all(line.as_bytes())
            } else {
                out.write_all(blocks.block(&[], Some(&packet), !args.raw).as_bytes())
            }
            .context("cannot write to standard output")?;
            seen += 1;
            if args.count.is_some_and(|n| seen >= n) {
                out.flush().context("cannot write to standard output")?;
                break 'run;
            }
        }
        out.flush().context("cannot write to standard output")?;
        match client.hub_state() {
            HubState::Unknown if !warned && started.elapsed() >= FIRST_ANSWER => {
                eprintln!(
                    "colony: no answer from a hub at {} yet; still trying (is `colony hub` running there? a hub run with --auth-all answers only packets signed with its key: --key FILE or COLONY_KEY)",
                    client.hub_addr()
                );
                warned = true;
            }
            HubState::Unreachable { silent_for } if !warned => {
                eprintln!(
                    "colony: no answer from a hub at {} for {:.0} s; still trying (is `colony hub` running?)",
                    client.hub_addr(),
                    silent_for.as_secs_f64()
                );
                warned = true;
            }
            HubState::Alive if warned => {
                eprintln!("colony: the hub at {} answers again", client.hub_addr());
                warned = false;
            }
            _ => {}
        }
    }
    // Leave no lease behind for the hub to keep until it expires.
    client.unsubscribe_all()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(subjects: &[Subject]) -> Vec<&str> {
        subjects.iter().map(Subject::as_str).collect()
    }

    #[test]
    fn a_subject_argument_that_is_no_set_is_refused_with_the_grammar() {
        assert_eq!(names(&parse_subjects("a,b").unwrap()), ["a", "b"]);
        let e = parse_subjects("radio stop").unwrap_err().to_string();
        assert!(
            e.contains("radio stop") && e.contains("SUBJECTS LINE"),
            "{e}"
        );
    }

    #[test]
    fn a_malformed_line_is_reported_with_its_position() {
        let e = build(&[Subject::new("a").unwrap()], 0, &["ball x 1 x 2"]).unwrap_err();
        let text = format!("{e:#}");
        assert!(
            text.contains("line 2") && text.contains("duplicate name `x`"),
            "{text}"
        );
    }

    #[test]
    fn packets_on_standard_input_must_go_where_the_subjects_say() {
        let text = "@ <a> 0\nx y 1\n\n@ <hub> 0\nstatus\n";
        let a = parse_subjects("a").unwrap();
        let e = format!("{:#}", packets_in(text, Some(&a)).unwrap_err());
        assert!(
            e.contains("packet 2 (line 4)") && e.contains("<hub>"),
            "{e}"
        );
        assert_eq!(packets_in(text, None).unwrap().len(), 2);
        let ab = parse_subjects("b,a").unwrap();
        assert_eq!(
            packets_in("@ <a> <b> 0\n", Some(&ab)).unwrap(),
            [b"@ <a> <b> 0\n".to_vec()]
        );
    }
}
