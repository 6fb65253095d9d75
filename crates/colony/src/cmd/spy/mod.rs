//! `colony spy`: a terminal view of a live hub (or of a traffic log), in the manner of
//! lcm-spy. Every channel with its rate, bandwidth, priority mix and last packet, updated in
//! place; Enter opens a channel, decoded field by field, with a plot of any numeric field;
//! `/` filters the channels; space pauses a log (or freezes a hub's view), and the arrows move
//! a log 10 s either way.
//!
//! The spy taps the hub (the `tap` request, as the monitor does: every packet the hub forwards,
//! whatever its subjects) and asks for the hub's status once a second, to tell whether the hub
//! lets it tap and how many packets it missed. What it knows is a sans-IO [`model::Spy`] fed
//! packets and time, and a log's playing is a sans-IO [`playback::Player`]; [`view`] draws
//! it with ratatui; this module owns the loop, the socket (or the log) and the terminal.

mod fields;
mod missed;
mod model;
mod playback;
mod view;

use std::io::IsTerminal as _;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, TryRecvError};
use std::time::{Duration, Instant};

use anyhow::Context as _;
use colony_client::{Delivery, HubState};
use colony_mcap::TrafficReader;
use colony_wire::{Reply, Request};
use ratatui::crossterm::event::{self, Event, KeyCode, KeyEvent, KeyEventKind, KeyModifiers};
use ratatui::DefaultTerminal;

use model::{Action, Feed, HubLink, Key, LogState, Spy};
use playback::{set_log_state, Played, Player};

use super::{Bounds, HubAddr};

/// The channel the spy leases, so the hub keeps its tap and answers its status requests.
pub const LEASE_CHANNEL: &str = "colony-spy";
/// The window rates are measured over: a tenth of a second to an hour.
pub const WINDOW: Bounds = Bounds::new(0.1, 3600.0, "seconds");
/// The screen is drawn this often (and at once after a key).
const DRAW_EVERY: Duration = Duration::from_millis(250);
const STATUS_EVERY: Duration = Duration::from_secs(1);
/// A socket error shows this long after it last happened.
const SHOW_FAILURE: Duration = Duration::from_secs(3);
/// The longest the loop waits for the hub's socket before looking at the keyboard.
const TICK: Duration = Duration::from_millis(15);
/// The receive buffer the spy asks for: a tap receives the whole hub's traffic, and the
/// default (about 208 KiB: five of the largest packets) drops a burst of it at the spy's socket.
const RECEIVE_BUFFER: usize = 4 << 20;
/// Datagrams or records taken in per round at most, so keys and drawing go on under a flood.
const BATCH: usize = 20_000;

#[derive(clap::Args, Debug)]
#[command(after_help = "\
Keys: arrows or j/k select a channel, Enter opens it; Tab, Shift-Tab or the arrows pick a \
numeric field to plot; Esc or q goes back, and quits from the table; Ctrl-C quits. \
/ types a filter: only the channels whose name or last packet holds it are listed (Enter \
keeps it, Esc clears it). Space freezes the view of a hub (the spy goes on counting) or \
pauses a log; space again goes on.

With --log, Left and Right move the log 10 s back or on, and Home starts it again (pick \
fields with Tab or Up and Down); a seek back reads the log again from its start.

The status line counts packets seen, packets the hub's status says it published that never \
reached the spy (missed), and datagrams that were no packet (unparsed).

With --log, the log is played at its recorded pace (faster with --speed), and rates are the \
recorded rates, per second of the log, whatever the speed; at its end the clock stops, so the \
last rates stay on the screen.")]
pub struct Args {
    #[command(flatten)]
    pub hub: HubAddr,
    /// Play this traffic log (a `.clog` or an MCAP, as `colony hub --log` writes them) instead
    /// of tapping a hub.
    #[arg(long, value_name = "FILE")]
    pub log: Option<PathBuf>,
    /// With --log: how many times faster than it was recorded.
    #[arg(long, default_value_t = 1.0, value_parser = super::SPEED, requires = "log")]
    pub speed: f64,
    /// Rates and bandwidths are the packets and bytes of the last this many seconds, over
    /// that span (as a rate from two of the hub's status reports is).
    #[arg(long, default_value_t = 1.0, value_parser = WINDOW, value_name = "SECONDS")]
    pub window: f64,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let window = super::seconds("--window", args.window)?;
    if !std::io::stdout().is_terminal() {
        anyhow::bail!(
            "colony spy draws in a terminal, and standard output is not one (for a list of packets, try `colony sub` or `colony log`)"
        );
    }
    // Everything that can fail for want of a hub or a file fails here, before the screen
    // changes, so the error reads as any other command's.
    let source = match &args.log {
        Some(file) => Source::Log(Box::new(TrafficReader::open(file)?), file.clone()),
        None => {
            // With the hub's key it taps as a console, which a hub never
            // refuses for too many taps.
            let client = args.hub.connect()?;
            Source::Hub(Box::new(client))
        }
    };
    let stop = super::stop_flag()?;
    // The terminal is restored however this ends: on return, on error (the guard) and on a
    // panic (ratatui's hook restores it before the message is printed).
    let mut terminal = ratatui::try_init().context("cannot set up the terminal")?;
    let _restore = Restore;
    match source {
        Source::Hub(client) => run_live(&mut terminal, *client, window, &stop),
        Source::Log(reader, file) => {
            let name = file.file_name().map_or_else(
                || file.display().to_string(),
                |n| n.to_string_lossy().into(),
            );
            let log = Log {
                reader: *reader,
                file,
                name,
            };
            run_log(&mut terminal, log, args.speed, window, &stop)
        }
    }
}

enum Source {
    Hub(Box<colony_client::UdpClient>),
    Log(Box<TrafficReader>, PathBuf),
}

/// A log being played: its reader, opened again to seek back, and its name for the title.
struct Log {
    reader: TrafficReader,
    file: PathBuf,
    name: String,
}

/// Puts the terminal back as it was when dropped.
struct Restore;

impl Drop for Restore {
    fn drop(&mut self) {
        ratatui::restore();
    }
}

fn run_live(
    terminal: &mut DefaultTerminal,
    mut client: colony_client::UdpClient,
    window: Duration,
    stop: &AtomicBool,
) -> anyhow::Result<()> {
    let input = terminal_events()?;
    enlarge_receive_buffer(&client, RECEIVE_BUFFER);
    client.set_standing(vec![Request::Tap, Request::About("colony spy".into())])?;
    client.subscribe(LEASE_CHANNEL)?;
    let me = client.local_addr().ok().map(|a| a.to_string());
    let start = Instant::now();
    let mut spy = Spy::new(
        Feed::Hub {
            addr: client.hub_addr().to_string(),
            state: HubLink::Waiting,
        },
        window,
    );
    let mut next_status = start;
    let mut next_draw = start;
    let mut last_failure: Option<(Instant, String)> = None;
    let result = loop {
        if stop.load(Ordering::Relaxed) {
            break Ok(());
        }
        // The network failing (a route gone, an interface down) is the hub's state, shown
        // until the client talks to it again, never the spy's end.
        let mut failed: Option<std::io::Error> = None;
        let now = Instant::now();
        if now >= next_status {
            next_status = now + STATUS_EVERY;
            if let Err(e) = client.request(&[Request::Status]) {
                failed = Some(e);
            }
        }
        if let Err(e) = client.poll(now) {
            failed = Some(e);
        }
        for _ in 0..BATCH {
            let at = start.elapsed();
            match client.recv_any() {
                Ok(Some(Delivery::Packet(p))) => spy.on_packet(at, &p),
                Ok(Some(Delivery::Reply(Reply::Status(r)))) => spy.on_status(at, &r, me.as_deref()),
                Ok(Some(Delivery::Reply(_))) => {}
                Ok(None) => break,
                Err(e) => {
                    failed = Some(e);
                    break;
                }
            }
        }
        spy.set_unparsed_elsewhere(client.malformed_count());
        if let Some(e) = failed {
            last_failure = Some((Instant::now(), e.to_string()));
        }
        let shown_failure = last_failure
            .as_ref()
            .filter(|(at, _)| at.elapsed() < SHOW_FAILURE)
            .map(|(_, why)| why.clone());
        if let Feed::Hub { state, .. } = &mut spy.feed {
            *state = match (shown_failure, client.hub_state()) {
                (Some(why), _) => HubLink::Failing(why),
                (None, HubState::Unknown) => HubLink::Waiting,
                (None, HubState::Alive) => HubLink::Alive,
                (None, HubState::Unreachable { silent_for }) => HubLink::Unreachable { silent_for },
            };
        }
        spy.set_now(start.elapsed());
        match keys(&mut spy, &input, |_, _| {})? {
            Some(Action::Quit) => break Ok(()),
            Some(_) => next_draw = Instant::now(),
            None => {}
        }
        if Instant::now() >= next_draw {
            terminal.draw(|f| view::draw(f, &spy))?;
            next_draw = Instant::now() + DRAW_EVERY;
        }
        let wake = [Some(next_draw), Some(next_status), client.next_deadline()]
            .into_iter()
            .flatten()
            .fold(Instant::now() + TICK, Instant::min);
        if client.wait(Some(wake)).is_err() {
            std::thread::sleep(wake.saturating_duration_since(Instant::now()));
        }
    };
    // Let the tap go at once: a hub lets only a few clients tap.
    let _ = client.unsubscribe_all();
    result
}

/// Asks for a receive buffer of `bytes`: the kernel caps a plain request at
/// `net.core.rmem_max`, which a privileged process may pass. Refusals are fine; what the
/// spy misses for want of room is counted (missed).
fn enlarge_receive_buffer(client: &colony_client::UdpClient, bytes: usize) {
    use colony_sys::buffers::{self, Buffer};
    let _ = buffers::set_size(client, Buffer::Receive, bytes, false);
    // Linux reports double the size asked for (it counts its bookkeeping).
    if buffers::size(client, Buffer::Receive).map_or(0, |b| b / 2) < bytes {
        let _ = buffers::set_size(client, Buffer::Receive, bytes, true);
    }
}

fn run_log(
    terminal: &mut DefaultTerminal,
    mut log: Log,
    speed: f64,
    window: Duration,
    stop: &AtomicBool,
) -> anyhow::Result<()> {
    let input = terminal_events()?;
    let start = Instant::now();
    let mut player = Player::new(speed);
    let mut spy = Spy::new(
        Feed::Log {
            file: log.name.clone(),
            speed,
            state: LogState::Playing,
        },
        window,
    );
    let mut next_draw = start;
    loop {
        if stop.load(Ordering::Relaxed) {
            return Ok(());
        }
        let next_due = match player.play(&mut spy, &mut log.reader, start.elapsed(), BATCH) {
            Played::Wait(due) => due.map(|d| start + d),
            Played::Ended => {
                set_log_state(&mut spy, LogState::Ended(log.reader.damage()));
                None
            }
        };
        let action = keys(&mut spy, &input, |spy, action| {
            if player.on_action(spy, action, start.elapsed()) {
                // A log is read forward only: a seek back reads it again from its start.
                match TrafficReader::open(&log.file) {
                    Ok(reader) => log.reader = reader,
                    Err(e) => player.fail(spy, e.to_string()),
                }
            }
        })?;
        match action {
            Some(Action::Quit) => return Ok(()),
            Some(_) => next_draw = Instant::now(),
            None => {}
        }
        // While a seek takes the records before its target, the screen shows where it goes
        // (drawn after its key) and nothing on the way.
        let pressed = action.is_some();
        if pressed || (Instant::now() >= next_draw && !player.seeking()) {
            terminal.draw(|f| view::draw(f, &spy))?;
            next_draw = Instant::now() + DRAW_EVERY;
        }
        let wake = [Some(next_draw), next_due]
            .into_iter()
            .flatten()
            .fold(Instant::now() + TICK, Instant::min);
        std::thread::sleep(wake.saturating_duration_since(Instant::now()));
    }
}

/// The terminal's events, read on a thread of their own. crossterm's reader never returns once
/// the terminal hangs up (it reads end of file again and again), so the loop must not wait in
/// it: it would spin there and never see the stop flag that SIGHUP sets. This thread may spin
/// then, until the loop sees the flag and the process ends.
fn terminal_events() -> anyhow::Result<Receiver<std::io::Result<Event>>> {
    let (tx, rx) = mpsc::sync_channel(256);
    std::thread::Builder::new()
        .name("spy-keys".into())
        .spawn(move || loop {
            let event = event::read();
            let failed = event.is_err();
            if tx.send(event).is_err() || failed {
                break;
            }
        })
        .context("cannot start the thread that reads the keyboard")?;
    Ok(rx)
}

/// Takes every key waiting, each action but quitting passed to `then` as it comes; `None`
/// when there was none.
fn keys(
    spy: &mut Spy,
    input: &Receiver<std::io::Result<Event>>,
    mut then: impl FnMut(&mut Spy, Action),
) -> anyhow::Result<Option<Action>> {
    let mut any = None;
    loop {
        let event = match input.try_recv() {
            Ok(event) => event.context("cannot read the terminal")?,
            Err(TryRecvError::Empty) => return Ok(any),
            Err(TryRecvError::Disconnected) => anyhow::bail!("the terminal's input ended"),
        };
        match event {
            Event::Key(k) if k.kind != KeyEventKind::Release => {
                let Some(key) = key_of(k, spy.typing()) else {
                    continue;
                };
                let action = spy.on_key(key);
                if action == Action::Quit {
                    return Ok(Some(Action::Quit));
                }
                then(spy, action);
                any = Some(Action::Continue);
            }
            Event::Resize(..) => any = Some(Action::Continue),
            _ => {}
        }
    }
}

/// The spy's key for a terminal's; while a filter is typed (`typing`), characters are
/// typed.
fn key_of(k: KeyEvent, typing: bool) -> Option<Key> {
    if k.modifiers.contains(KeyModifiers::CONTROL) {
        return matches!(k.code, KeyCode::Char('c' | 'd')).then_some(Key::Quit);
    }
    if typing {
        return Some(match k.code {
            KeyCode::Char(c) => Key::Char(c),
            KeyCode::Backspace => Key::Erase,
            KeyCode::Enter => Key::Open,
            KeyCode::Esc => Key::Back,
            KeyCode::Up => Key::Up,
            KeyCode::Down => Key::Down,
            KeyCode::PageUp => Key::PageUp,
            KeyCode::PageDown => Key::PageDown,
            _ => return None,
        });
    }
    Some(match k.code {
        KeyCode::Up | KeyCode::Char('k') => Key::Up,
        KeyCode::Down | KeyCode::Char('j') => Key::Down,
        KeyCode::PageUp => Key::PageUp,
        KeyCode::PageDown => Key::PageDown,
        KeyCode::Home => Key::Home,
        KeyCode::Char('g') => Key::Top,
        KeyCode::End | KeyCode::Char('G') => Key::End,
        KeyCode::Enter => Key::Open,
        KeyCode::Tab | KeyCode::Char('l') => Key::Next,
        KeyCode::BackTab | KeyCode::Char('h') => Key::Previous,
        KeyCode::Right => Key::Right,
        KeyCode::Left => Key::Left,
        KeyCode::Char('/') => Key::Search,
        KeyCode::Char(' ') => Key::Pause,
        KeyCode::Esc | KeyCode::Backspace | KeyCode::Char('q') => Key::Back,
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_map_as_the_help_says() {
        let k = |code| key_of(KeyEvent::new(code, KeyModifiers::NONE), false);
        assert_eq!(k(KeyCode::Char('j')), Some(Key::Down));
        assert_eq!(k(KeyCode::Up), Some(Key::Up));
        assert_eq!(k(KeyCode::Enter), Some(Key::Open));
        assert_eq!(k(KeyCode::Tab), Some(Key::Next));
        assert_eq!(k(KeyCode::BackTab), Some(Key::Previous));
        assert_eq!(k(KeyCode::Esc), Some(Key::Back));
        assert_eq!(k(KeyCode::Char('q')), Some(Key::Back));
        assert_eq!(k(KeyCode::Char('x')), None);
        assert_eq!(k(KeyCode::Char('/')), Some(Key::Search));
        assert_eq!(k(KeyCode::Char(' ')), Some(Key::Pause));
        assert_eq!(k(KeyCode::Left), Some(Key::Left));
        assert_eq!(k(KeyCode::Home), Some(Key::Home));
        assert_eq!(k(KeyCode::Char('g')), Some(Key::Top));
        let ctrl_c = KeyEvent::new(KeyCode::Char('c'), KeyModifiers::CONTROL);
        assert_eq!(key_of(ctrl_c, false), Some(Key::Quit));
        // Typing a filter, every character is typed, and Ctrl-C still quits.
        let t = |code| key_of(KeyEvent::new(code, KeyModifiers::NONE), true);
        for c in ['q', 'j', ' ', '/', 'g', 'é'] {
            assert_eq!(t(KeyCode::Char(c)), Some(Key::Char(c)));
        }
        assert_eq!(t(KeyCode::Backspace), Some(Key::Erase));
        assert_eq!(t(KeyCode::Enter), Some(Key::Open));
        assert_eq!(t(KeyCode::Esc), Some(Key::Back));
        assert_eq!(t(KeyCode::Left), None);
        assert_eq!(key_of(ctrl_c, true), Some(Key::Quit));
    }
}
