//! `colony pub` and `colony sub`.

use std::io::{Read as _, Write as _};
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use anyhow::Context as _;
use colony_client::HubState;
use colony_wire::{split_packets, Packet, PacketBuilder, Priority, Subject};

use super::HubAddr;

#[derive(clap::Args, Debug)]
pub struct PubArgs {
    #[command(flatten)]
    pub hub: HubAddr,
    /// The packet's priority.
    #[arg(long, short, default_value_t = 0, allow_negative_numbers = true)]
    pub priority: i32,
    /// Subjects, then body lines: `colony pub radio 'cmd id 3 vl 0.2 vr 0.2'`.
    /// An argument with a blank in it starts the lines; with no lines, the
    /// body is read from standard input (where text starting with `@` is
    /// taken as whole packets, each published as it stands).
    #[arg(required = true, value_name = "SUBJECT... LINE...")]
    pub words: Vec<String>,
}

#[derive(clap::Args, Debug)]
pub struct SubArgs {
    #[command(flatten)]
    pub hub: HubAddr,
    /// Stop after this many packets.
    #[arg(long, short = 'n')]
    pub count: Option<u64>,
    /// Subjects to subscribe to; each packet to any of them is printed.
    #[arg(required = true, value_name = "SUBJECT")]
    pub subjects: Vec<String>,
}

/// Splits `pub`'s words into subjects and lines.
fn split_words(words: &[String]) -> anyhow::Result<(Vec<Subject>, Vec<&str>)> {
    let first_line = words
        .iter()
        .position(|w| w.contains(char::is_whitespace))
        .unwrap_or(words.len());
    let subjects = words[..first_line]
        .iter()
        .map(|w| Subject::new(w).map_err(anyhow::Error::from))
        .collect::<anyhow::Result<Vec<_>>>()?;
    if subjects.is_empty() {
        anyhow::bail!(
            "give at least one subject before the lines, e.g. `colony pub radio 'cmd id 3 vl 0.2'`"
        );
    }
    Ok((
        subjects,
        words[first_line..].iter().map(String::as_str).collect(),
    ))
}

fn build(subjects: &[Subject], priority: i32, lines: &[&str]) -> anyhow::Result<Vec<u8>> {
    let mut b = PacketBuilder::new(subjects, Priority(priority));
    for l in lines.iter().flat_map(|l| l.lines()) {
        b.raw_line(l);
    }
    b.finish()
        .context("malformed packet (the header counts as line 1)")
}

pub fn publish(args: PubArgs) -> anyhow::Result<()> {
    let (subjects, lines) = split_words(&args.words)?;
    let mut packets = Vec::new();
    if lines.is_empty() {
        let mut text = String::new();
        std::io::stdin()
            .read_to_string(&mut text)
            .context("cannot read packets from standard input")?;
        if text.trim_start().starts_with('@') {
            for (i, chunk) in split_packets(&text).into_iter().enumerate() {
                Packet::parse(chunk.as_bytes())
                    .with_context(|| format!("packet {} on standard input", i + 1))?;
                packets.push(chunk.as_bytes().to_vec());
            }
        } else {
            packets.push(build(&subjects, args.priority, &[text.as_str()])?);
        }
    } else {
        packets.push(build(&subjects, args.priority, &lines)?);
    }
    let mut client = args.hub.connect()?;
    for p in &packets {
        client.publish(p)?;
    }
    Ok(())
}

pub fn subscribe(args: SubArgs) -> anyhow::Result<()> {
    let mut client = args.hub.connect()?;
    for s in &args.subjects {
        client.subscribe(s)?;
    }
    let stop = super::stop_flag()?;
    let stdout = std::io::stdout();
    let mut seen = 0u64;
    let mut warned = false;
    'run: while !stop.load(Ordering::Relaxed) {
        let wake = client
            .next_deadline()
            .map(|d| d.min(Instant::now() + Duration::from_millis(250)));
        client.wait(wake)?;
        client.poll(Instant::now())?;
        let mut out = stdout.lock();
        while let Some(packet) = client.recv()? {
            write!(out, "{packet}").context("cannot write to standard output")?;
            seen += 1;
            if args.count.is_some_and(|n| seen >= n) {
                out.flush().context("cannot write to standard output")?;
                break 'run;
            }
        }
        out.flush().context("cannot write to standard output")?;
        match client.hub_state() {
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

    #[test]
    fn words_with_blanks_start_the_lines() {
        let words: Vec<String> = ["a", "b", "x y 1", "z"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        let (subjects, lines) = split_words(&words).unwrap();
        assert_eq!(
            subjects.iter().map(Subject::as_str).collect::<Vec<_>>(),
            ["a", "b"]
        );
        assert_eq!(lines, ["x y 1", "z"]);
    }

    #[test]
    fn a_bad_subject_is_named() {
        let words = vec!["bad!subject".to_string()];
        let e = split_words(&words).unwrap_err().to_string();
        assert!(e.contains("bad!subject"), "{e}");
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
}
