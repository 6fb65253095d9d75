//! The subsumption arbitrator: layered behaviours, exactly one in control.
//!
//! After Brooks' subsumption architecture as used by Hristoskova et al. (sec.
//! 4.1): a complicated behaviour is split into simple [`Behaviour`]s stacked in
//! priority layers (reflexes over commands over squad behaviours), and an
//! [`Arbitrator`] activates one and only one of them per tick: the
//! highest-priority one that wants control.
//!
//! The crate is generic over the context `C` a behaviour reads and acts on (a
//! robot's sensors and wheel command, a squad's state and outbox), has no
//! dependencies, no clock and no threads: the caller owns the loop and calls
//! [`Arbitrator::step`] once per tick. It knows nothing about robots or games.
//!
//! # Example
//!
//! A robot with a collision reflex over a `GoTo` command over idling. The
//! reflex preempts the command while the obstacle is close and hands control
//! back when it is gone.
//!
//! ```
//! use colony_behave::{Arbitrator, Behaviour, Reason};
//!
//! #[derive(Default)]
//! struct Robot {
//!     sonar_cm: f64,
//!     target: Option<(f64, f64)>,
//!     log: Vec<&'static str>,
//! }
//!
//! struct Avoid;
//! impl Behaviour<Robot> for Avoid {
//!     fn name(&self) -> &str { "avoid" }
//!     fn wants_control(&mut self, r: &Robot) -> Option<Reason> {
//!         (r.sonar_cm < 15.0).then(|| format!("sonar: obstacle at {} cm", r.sonar_cm).into())
//!     }
//!     fn act(&mut self, r: &mut Robot) { r.log.push("turn away"); }
//! }
//!
//! struct GoTo;
//! impl Behaviour<Robot> for GoTo {
//!     fn name(&self) -> &str { "goto" }
//!     fn wants_control(&mut self, r: &Robot) -> Option<Reason> {
//!         r.target.map(|_| "command GoTo".into())
//!     }
//!     fn act(&mut self, r: &mut Robot) { r.log.push("drive to target"); }
//!     fn suppressed(&mut self, r: &mut Robot) { r.log.push("goto preempted: stop wheels"); }
//! }
//!
//! struct Idle;
//! impl Behaviour<Robot> for Idle {
//!     fn name(&self) -> &str { "idle" }
//!     fn wants_control(&mut self, _r: &Robot) -> Option<Reason> { Some("nothing to do".into()) }
//!     fn act(&mut self, r: &mut Robot) { r.log.push("stand still"); }
//! }
//!
//! let mut arbitrator = Arbitrator::new();
//! arbitrator.add(0, Idle);
//! arbitrator.add(10, GoTo);
//! arbitrator.add(20, Avoid);
//!
//! let mut robot = Robot { sonar_cm: 100.0, ..Robot::default() };
//! assert_eq!(arbitrator.step(&mut robot).unwrap().name, "idle");
//!
//! robot.target = Some((50.0, 0.0));
//! let d = arbitrator.step(&mut robot).unwrap();
//! assert_eq!((d.name.as_str(), d.changed), ("goto", true));
//!
//! robot.sonar_cm = 12.0; // the reflex preempts the command
//! let d = arbitrator.step(&mut robot).unwrap();
//! assert_eq!(d.name, "avoid");
//! assert_eq!(d.reason, "sonar: obstacle at 12 cm");
//!
//! robot.sonar_cm = 80.0; // ...and hands control back
//! let d = arbitrator.step(&mut robot).unwrap();
//! assert_eq!((d.name.as_str(), d.since), ("goto", 3));
//! assert_eq!(
//!     robot.log,
//!     ["stand still", "drive to target", "goto preempted: stop wheels", "turn away", "drive to target"]
//! );
//! ```
#![forbid(unsafe_code)]
#![warn(missing_docs)]

use std::borrow::Cow;
use std::fmt;

/// Why a behaviour wants control, for the monitor: "bumper front pressed",
/// "sonar: obstacle at 12 cm". Static text costs nothing; `format!(..).into()`
/// when it carries a measurement.
pub type Reason = Cow<'static, str>;

/// One simple behavioural module: it says when it wants control and what it
/// does while it has it.
///
/// `C` is whatever the behaviour reads and writes (sensors, the current
/// command, an outbox). It is `?Sized` so a trait object can be the context.
pub trait Behaviour<C: ?Sized> {
    /// A short name for the monitor and logs ("avoid", "goto").
    fn name(&self) -> &str;

    /// `Some(reason)` when this behaviour wants control now.
    ///
    /// Takes `&mut self` so a behaviour can keep state across ticks, such as a
    /// reflex that must finish its manoeuvre after the trigger has gone. It is
    /// only asked while no higher-priority behaviour wants control; see
    /// [`Arbitrator::step`].
    fn wants_control(&mut self, ctx: &C) -> Option<Reason>;

    /// Acts for one tick while in control.
    fn act(&mut self, ctx: &mut C);

    /// Called once when a higher-priority behaviour takes control away, so the
    /// behaviour can stop its motors or remember to resume. Not called when it
    /// gives control up itself (its `wants_control` returned `None`).
    fn suppressed(&mut self, _ctx: &mut C) {}
}

/// Identifies a behaviour within one [`Arbitrator`]: the order it was added
/// in, starting at 0.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct BehaviourId(pub usize);

/// Which behaviour is in control and why: what the monitor shows.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Decision {
    /// The behaviour in control.
    pub behaviour: BehaviourId,
    /// Its name.
    pub name: String,
    /// Its priority.
    pub priority: i32,
    /// Why it wants control, as of this tick.
    pub reason: Reason,
    /// The tick (see [`Arbitrator::tick`]) at which it took control; it has
    /// been in control continuously since.
    pub since: u64,
    /// True when control moved to this behaviour on this tick.
    pub changed: bool,
}

impl fmt::Display for Decision {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} (priority {}, since tick {}): {}",
            self.name, self.priority, self.since, self.reason
        )
    }
}

struct Entry<C: ?Sized> {
    id: BehaviourId,
    priority: i32,
    behaviour: Box<dyn Behaviour<C> + Send>,
}

/// Activates one and only one behaviour per tick: the highest-priority one
/// that wants control.
///
/// Behaviours must be `Send` so that an arbitrator can be moved to the thread
/// that runs its robot or squad.
pub struct Arbitrator<C: ?Sized> {
    /// Highest priority first; equal priorities in the order they were added.
    entries: Vec<Entry<C>>,
    active: Option<Decision>,
    tick: u64,
}

impl<C: ?Sized> Default for Arbitrator<C> {
    fn default() -> Self {
        Arbitrator::new()
    }
}

impl<C: ?Sized> fmt::Debug for Arbitrator<C> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Arbitrator")
            .field("behaviours", &self.behaviours().collect::<Vec<_>>())
            .field("active", &self.active)
            .field("tick", &self.tick)
            .finish()
    }
}

impl<C: ?Sized> Arbitrator<C> {
    /// An arbitrator with no behaviours; [`step`](Self::step) returns `None`
    /// until one is added.
    pub fn new() -> Self {
        Arbitrator {
            entries: Vec::new(),
            active: None,
            tick: 0,
        }
    }

    /// Adds a behaviour at `priority` (higher wins). Among equal priorities the
    /// one added first wins, so arbitration never depends on anything but the
    /// order of the calls.
    pub fn add(
        &mut self,
        priority: i32,
        behaviour: impl Behaviour<C> + Send + 'static,
    ) -> BehaviourId {
        self.add_boxed(priority, Box::new(behaviour))
    }

    /// [`add`](Self::add) for a behaviour that is already boxed.
    pub fn add_boxed(
        &mut self,
        priority: i32,
        behaviour: Box<dyn Behaviour<C> + Send>,
    ) -> BehaviourId {
        let id = BehaviourId(self.entries.len());
        // After every entry of equal or higher priority: ties keep insertion order.
        let at = self.entries.partition_point(|e| e.priority >= priority);
        self.entries.insert(
            at,
            Entry {
                id,
                priority,
                behaviour,
            },
        );
        id
    }

    /// Runs one tick: asks the behaviours from the highest priority down
    /// whether they want control; the first that does acts, and the ones below
    /// it are not asked at all (the paper's "one and only one behaviour" is
    /// activated, and a lower layer's trigger cannot matter while a higher one
    /// holds control). Returns the decision, or `None` when no behaviour
    /// wants control (nothing acts then).
    ///
    /// When control moves to a behaviour that ranks higher (higher priority,
    /// or equal priority and added earlier), the one that had it is told
    /// through [`Behaviour::suppressed`] before the new one acts. When it moves
    /// down, the previous one has declined by itself and is not told.
    pub fn step(&mut self, ctx: &mut C) -> Option<&Decision> {
        let now = self.tick;
        self.tick += 1;

        let winner = self
            .entries
            .iter_mut()
            .enumerate()
            .find_map(|(rank, e)| e.behaviour.wants_control(ctx).map(|reason| (rank, reason)));

        // Taken before the early return: a tick in which nobody acts leaves
        // nobody active.
        let previous = self.active.take();
        let (rank, reason) = winner?;
        let winner_id = self.entries[rank].id;
        let decision = match previous {
            Some(mut d) if d.behaviour == winner_id => {
                d.reason = reason;
                d.changed = false;
                d
            }
            previous => {
                if let Some(prev) = previous {
                    // Entries are ranked by priority then insertion, so the
                    // previous one was preempted exactly when it ranks below
                    // the winner; above it, it must have declined this tick.
                    if let Some(below) = self.entries[rank + 1..]
                        .iter_mut()
                        .find(|e| e.id == prev.behaviour)
                    {
                        below.behaviour.suppressed(ctx);
                    }
                }
                let entry = &self.entries[rank];
                Decision {
                    behaviour: entry.id,
                    name: entry.behaviour.name().to_owned(),
                    priority: entry.priority,
                    reason,
                    since: now,
                    changed: true,
                }
            }
        };
        self.entries[rank].behaviour.act(ctx);
        self.active = Some(decision);
        self.active.as_ref()
    }

    /// The behaviour that acted on the last tick and why, if any did.
    pub fn active(&self) -> Option<&Decision> {
        self.active.as_ref()
    }

    /// The behaviours in arbitration order (highest priority first), as
    /// `(priority, name)` for display.
    pub fn behaviours(&self) -> impl Iterator<Item = (i32, &str)> + '_ {
        self.entries
            .iter()
            .map(|e| (e.priority, e.behaviour.name()))
    }

    /// How many ticks have been run. The first [`step`](Self::step) is tick 0,
    /// so after it this returns 1.
    pub fn tick(&self) -> u64 {
        self.tick
    }

    /// How many behaviours have been added.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// True when no behaviour has been added.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A shared record of what every behaviour was asked and did, in order.
    #[derive(Default)]
    struct Ctx {
        /// Names of the behaviours that currently want control.
        wanting: Vec<&'static str>,
        events: Vec<String>,
    }

    impl Ctx {
        fn want(&mut self, names: &[&'static str]) {
            self.wanting = names.to_vec();
            self.events.clear();
        }
    }

    struct Probe(&'static str);

    impl Behaviour<Ctx> for Probe {
        fn name(&self) -> &str {
            self.0
        }
        fn wants_control(&mut self, ctx: &Ctx) -> Option<Reason> {
            ctx.wanting
                .contains(&self.0)
                .then(|| format!("{} triggered", self.0).into())
        }
        fn act(&mut self, ctx: &mut Ctx) {
            ctx.events.push(format!("act {}", self.0));
        }
        fn suppressed(&mut self, ctx: &mut Ctx) {
            ctx.events.push(format!("suppressed {}", self.0));
        }
    }

    /// Records which behaviours were asked, through interior state the test reads back.
    struct Asked(
        &'static str,
        std::sync::Arc<std::sync::Mutex<Vec<&'static str>>>,
    );

    impl Behaviour<Ctx> for Asked {
        fn name(&self) -> &str {
            self.0
        }
        fn wants_control(&mut self, ctx: &Ctx) -> Option<Reason> {
            self.1.lock().unwrap().push(self.0);
            ctx.wanting
                .contains(&self.0)
                .then_some(Cow::Borrowed("yes"))
        }
        fn act(&mut self, ctx: &mut Ctx) {
            ctx.events.push(format!("act {}", self.0));
        }
    }

    fn layered() -> Arbitrator<Ctx> {
        let mut a = Arbitrator::new();
        // Added out of order: priority, not insertion, decides.
        a.add(10, Probe("command"));
        a.add(20, Probe("reflex"));
        a.add(0, Probe("squad"));
        a
    }

    fn acted(ctx: &Ctx) -> Vec<&str> {
        ctx.events
            .iter()
            .filter_map(|e| e.strip_prefix("act "))
            .collect()
    }

    #[test]
    fn empty_arbitrator_decides_nothing() {
        let mut a: Arbitrator<Ctx> = Arbitrator::new();
        assert!(a.is_empty());
        assert!(a.step(&mut Ctx::default()).is_none());
        assert!(a.active().is_none());
        assert_eq!(a.tick(), 1);
    }

    #[test]
    fn nobody_wanting_control_means_nobody_acts() {
        let mut a = layered();
        let mut ctx = Ctx::default();
        assert!(a.step(&mut ctx).is_none());
        assert!(ctx.events.is_empty());
    }

    #[test]
    fn highest_priority_that_wants_control_wins() {
        let mut a = layered();
        let mut ctx = Ctx::default();
        ctx.want(&["squad", "command", "reflex"]);
        let d = a.step(&mut ctx).unwrap();
        assert_eq!((d.name.as_str(), d.priority), ("reflex", 20));
        assert_eq!(d.reason, "reflex triggered");
        assert_eq!(d.behaviour, BehaviourId(1));

        ctx.want(&["squad", "command"]);
        assert_eq!(a.step(&mut ctx).unwrap().name, "command");
    }

    #[test]
    fn exactly_one_behaviour_acts_per_step() {
        let mut a = layered();
        let mut ctx = Ctx::default();
        for wanting in [
            &["squad"][..],
            &["squad", "command"],
            &["squad", "command", "reflex"],
            &["reflex", "squad"],
            &["command"],
        ] {
            ctx.want(wanting);
            let d = a.step(&mut ctx).unwrap().clone();
            assert_eq!(acted(&ctx), [d.name.as_str()], "wanting {wanting:?}");
        }
    }

    #[test]
    fn lower_behaviours_are_not_asked_once_one_wants_control() {
        let log = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
        let mut a = Arbitrator::new();
        a.add(0, Asked("low", log.clone()));
        a.add(5, Asked("mid", log.clone()));
        a.add(9, Asked("high", log.clone()));
        let mut ctx = Ctx::default();
        ctx.want(&["mid", "low"]);
        a.step(&mut ctx);
        assert_eq!(*log.lock().unwrap(), ["high", "mid"]);
    }

    #[test]
    fn preempted_behaviour_is_told_once_before_the_new_one_acts() {
        let mut a = layered();
        let mut ctx = Ctx::default();
        ctx.want(&["command"]);
        a.step(&mut ctx);
        ctx.want(&["command", "reflex"]);
        let d = a.step(&mut ctx).unwrap();
        assert!(d.changed);
        assert_eq!(ctx.events, ["suppressed command", "act reflex"]);

        // Staying preempted does not repeat the notice.
        ctx.want(&["command", "reflex"]);
        assert!(!a.step(&mut ctx).unwrap().changed);
        assert_eq!(ctx.events, ["act reflex"]);
    }

    #[test]
    fn behaviour_that_gives_up_control_is_not_told_it_was_suppressed() {
        let mut a = layered();
        let mut ctx = Ctx::default();
        ctx.want(&["reflex"]);
        a.step(&mut ctx);
        ctx.want(&["command"]);
        a.step(&mut ctx);
        assert_eq!(ctx.events, ["act command"]);
        ctx.want(&[]);
        assert!(a.step(&mut ctx).is_none());
        assert!(ctx.events.is_empty());
    }

    #[test]
    fn control_returns_to_the_lower_behaviour_when_the_higher_stops_wanting_it() {
        let mut a = layered();
        let mut ctx = Ctx::default();
        ctx.want(&["command"]);
        let first = a.step(&mut ctx).unwrap().clone();
        assert_eq!((first.since, first.changed), (0, true));

        ctx.want(&["command"]);
        let d = a.step(&mut ctx).unwrap();
        assert_eq!((d.since, d.changed), (0, false));

        ctx.want(&["command", "reflex"]);
        a.step(&mut ctx);
        ctx.want(&["command", "reflex"]);
        a.step(&mut ctx);

        ctx.want(&["command"]);
        let d = a.step(&mut ctx).unwrap();
        assert_eq!(d.name, "command");
        assert_eq!((d.since, d.changed), (4, true));
        assert_eq!(a.tick(), 5);
        assert_eq!(a.active().unwrap().name, "command");
    }

    #[test]
    fn equal_priorities_go_to_the_one_added_first() {
        let mut a = Arbitrator::new();
        a.add(1, Probe("first"));
        a.add(1, Probe("second"));
        a.add(1, Probe("third"));
        let mut ctx = Ctx::default();
        ctx.want(&["third", "second", "first"]);
        assert_eq!(a.step(&mut ctx).unwrap().name, "first");
        ctx.want(&["third", "second"]);
        assert_eq!(a.step(&mut ctx).unwrap().name, "second");
        // Moving between equals is not a preemption.
        assert_eq!(ctx.events, ["act second"]);
        let order: Vec<_> = a.behaviours().collect();
        assert_eq!(order, [(1, "first"), (1, "second"), (1, "third")]);
    }

    #[test]
    fn behaviours_are_listed_highest_priority_first() {
        let a = layered();
        let listed: Vec<_> = a.behaviours().collect();
        assert_eq!(listed, [(20, "reflex"), (10, "command"), (0, "squad")]);
        assert_eq!(a.len(), 3);
    }

    #[test]
    fn reason_is_refreshed_every_tick_while_in_control() {
        struct Counting(u32);
        impl Behaviour<Ctx> for Counting {
            fn name(&self) -> &str {
                "counting"
            }
            fn wants_control(&mut self, _: &Ctx) -> Option<Reason> {
                self.0 += 1;
                Some(format!("asked {} times", self.0).into())
            }
            fn act(&mut self, _: &mut Ctx) {}
        }
        let mut a = Arbitrator::new();
        a.add(0, Counting(0));
        let mut ctx = Ctx::default();
        a.step(&mut ctx);
        let d = a.step(&mut ctx).unwrap();
        assert_eq!(d.reason, "asked 2 times");
        assert_eq!(
            d.to_string(),
            "counting (priority 0, since tick 0): asked 2 times"
        );
    }

    #[test]
    fn arbitrator_over_an_unsized_context() {
        struct Push;
        impl Behaviour<dyn std::fmt::Write> for Push {
            fn name(&self) -> &str {
                "push"
            }
            fn wants_control(&mut self, _: &dyn std::fmt::Write) -> Option<Reason> {
                Some("always".into())
            }
            fn act(&mut self, out: &mut (dyn std::fmt::Write + 'static)) {
                out.write_str("x").unwrap();
            }
        }
        let mut a: Arbitrator<dyn std::fmt::Write> = Arbitrator::new();
        a.add(0, Push);
        let mut out = String::new();
        a.step(&mut out);
        a.step(&mut out);
        assert_eq!(out, "xx");
    }
}
