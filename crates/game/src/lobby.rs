//! The pre-match (the paper configures the game in the client before it starts): each player
//! spends the budget on robots' types, health and power and divides them into squads, and says
//! when they are ready; the bot's teams are set and ready from the start. The lobby publishes
//! where things stand on `game.lobby` twice a second and at every change, refuses a setup the
//! rules or the map do not allow with a `refused` event saying why, and is done when every
//! team is ready: [`Lobby::setups`] are then the teams the match is played with.

use std::collections::{BTreeSet, VecDeque};
use std::sync::Arc;
use std::time::Duration;

use colony_node::{Node, Time};
use colony_wire::{Packet, Subject};

use crate::logic::roster;
use crate::map::Battlefield;
use crate::protocol::{self, Event, KindOffer, LobbyState, LobbyStatus, LobbyTeam, PlayerCommand};
use crate::rules::{KindRules, RobotKind, Rules, TeamSetup, MAX_UPGRADE, UPGRADE_STEP};

/// The lobby is published this often, for pages that open late.
const PUBLISH_EVERY: Duration = Duration::from_millis(500);
/// The map goes out with every this many lobby states, so a page opened
/// during the pre-match draws the battlefield while its player picks units
/// (the river decides who needs amphibians) within a few seconds.
const MAP_EVERY: u64 = 6;
/// A change is published within this, and no sooner after the last: a flood of packets (forged
/// or not) makes ten lobby packets a second, not one each.
const CHANGE_GAP: Duration = Duration::from_millis(100);

struct Seat {
    setup: TeamSetup,
    ready: bool,
    bot: bool,
}

/// The pre-match, as a node of the game.
pub struct Lobby {
    field: Arc<Battlefield>,
    rules: Rules,
    seats: Vec<Seat>,
    subs: BTreeSet<Subject>,
    outbox: VecDeque<Vec<u8>>,
    next_publish: Time,
    /// Lobby states published so far.
    published: u64,
}

impl Lobby {
    /// A lobby for these teams, starting from these setups; `bots` are the teams the built-in
    /// player plays (ready from the start).
    pub fn new(
        field: Arc<Battlefield>,
        rules: Rules,
        teams: Vec<TeamSetup>,
        bots: &[String],
    ) -> Lobby {
        let subs = protocol::subjects(teams.iter().map(|t| protocol::player_channel(&t.name)));
        let seats = teams
            .into_iter()
            .map(|setup| {
                let bot = bots.contains(&setup.name);
                Seat {
                    setup,
                    ready: bot,
                    bot,
                }
            })
            .collect();
        Lobby {
            field,
            rules,
            seats,
            subs,
            outbox: VecDeque::new(),
            next_publish: Time::ZERO,
            published: 0,
        }
    }

    /// Every team is ready.
    pub fn is_done(&self) -> bool {
        self.seats.iter().all(|s| s.ready)
    }

    /// The teams as they are set up now.
    pub fn setups(&self) -> Vec<TeamSetup> {
        self.seats.iter().map(|s| s.setup.clone()).collect()
    }

    /// What the players see.
    pub fn state(&self) -> LobbyState {
        LobbyState {
            status: if self.is_done() {
                LobbyStatus::Started
            } else {
                LobbyStatus::Drafting
            },
            budget: self.rules.budget,
            max_squads: u32::try_from(self.rules.max_squads).unwrap_or(u32::MAX),
            upgrade: UPGRADE_STEP,
            max_upgrade: MAX_UPGRADE,
            kinds: RobotKind::ALL
                .iter()
                .map(|&kind| {
                    let s = kind.stats();
                    KindOffer {
                        kind,
                        cost: s.cost,
                        health: s.health,
                        power: s.damage,
                        speed: s.speed_cm_s,
                        range: s.range_cm,
                        amphibious: s.amphibious,
                    }
                })
                .collect(),
            teams: self
                .seats
                .iter()
                .map(|s| LobbyTeam {
                    name: s.setup.name.clone(),
                    ready: s.ready,
                    bot: s.bot,
                    cost: s.setup.cost(),
                    setup: s.setup.to_string(),
                })
                .collect(),
        }
    }

    /// A team's new setup, checked against the rules and the map; `ready` to play with it.
    fn set_up(&mut self, team: &str, text: &str, ready: bool) -> Result<(), String> {
        let i = self.seat(team)?;
        let setup = TeamSetup::parse(team, text).map_err(|e| e.to_string())?;
        setup.check(&self.rules).map_err(|e| e.to_string())?;
        roster(&self.field, &self.rules, std::slice::from_ref(&setup))
            .map_err(|e| e.to_string())?;
        let seat = &mut self.seats[i];
        seat.setup = setup;
        seat.ready = ready;
        Ok(())
    }

    fn seat(&self, team: &str) -> Result<usize, String> {
        let i = self
            .seats
            .iter()
            .position(|s| s.setup.name == team)
            .ok_or_else(|| format!("there is no team {team} in this match"))?;
        if self.seats[i].bot {
            return Err(format!("team {team} is played by the built-in player"));
        }
        Ok(i)
    }

    fn obey(&mut self, c: PlayerCommand) -> Result<(), String> {
        match c {
            PlayerCommand::Setup {
                team,
                squads,
                ready,
            } => self.set_up(&team, &squads, ready).map_err(|why| {
                // A refused setup leaves the team as it was, and not ready.
                if let Ok(i) = self.seat(&team) {
                    self.seats[i].ready = false;
                }
                format!("{team} setup: {why}")
            }),
            PlayerCommand::Ready { team, ready } => {
                let i = self.seat(&team).map_err(|why| format!("{team}: {why}"))?;
                self.seats[i].ready = ready;
                Ok(())
            }
            other => Err(format!(
                "{}: the match has not started; set up your team and say you are ready",
                other.team()
            )),
        }
    }

    fn publish(&mut self, now: Time) {
        if self.published % MAP_EVERY == 0 {
            match protocol::map_message(&self.field).encode() {
                Ok(parts) => self.outbox.extend(parts),
                Err(e) => tracing::warn!(error = %e, "cannot send the map"),
            }
        }
        self.published += 1;
        match self.state().encode() {
            Ok(p) => self.outbox.push_back(p),
            Err(e) => tracing::warn!(error = %e, "the lobby is too large to send"),
        }
        self.next_publish = now + PUBLISH_EVERY;
    }

    fn refuse(&mut self, text: String) {
        let e = Event {
            time: 0.0,
            kind: "refused".into(),
            text,
        };
        if let Ok(p) = e.encode() {
            self.outbox.push_back(p);
        }
    }
}

impl Node for Lobby {
    fn subscriptions(&self) -> &BTreeSet<Subject> {
        &self.subs
    }

    fn handle_packet(&mut self, now: Time, packet: &Packet<'_>) {
        let Some(team) = packet
            .subjects()
            .find_map(|s| s.strip_prefix("game.player."))
        else {
            return;
        };
        let team = team.to_string();
        match PlayerCommand::decode(&team, packet) {
            Ok(cmds) => {
                // One refusal per packet, however many lines it has.
                let mut refused = Vec::new();
                for c in cmds {
                    if let Err(why) = self.obey(c) {
                        refused.push(why);
                    }
                }
                if let Some(text) = protocol::player::one_refusal(&refused) {
                    self.refuse(text);
                }
            }
            Err(e) => self.refuse(format!("a bad command from {team}: {e}")),
        }
        self.next_publish = self.next_publish.min(now + CHANGE_GAP);
    }

    fn poll_timeout(&self) -> Option<Time> {
        Some(self.next_publish)
    }

    fn handle_timeout(&mut self, now: Time) {
        if now >= self.next_publish {
            self.publish(now);
        }
    }

    fn poll_transmit(&mut self) -> Option<Vec<u8>> {
        self.outbox.pop_front()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rules::Mode;

    fn lobby() -> Lobby {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../maps/ctf.map");
        let field = Arc::new(Battlefield::from_file(&path).unwrap());
        let teams = vec![
            TeamSetup::parse("red", "alpha:tank,infantry").unwrap(),
            TeamSetup::parse("blue", "alpha:scout").unwrap(),
        ];
        Lobby::new(
            field,
            Rules::new(Mode::CaptureTheFlag),
            teams,
            &["blue".into()],
        )
    }

    fn say(l: &mut Lobby, c: PlayerCommand) -> Vec<String> {
        let bytes = c.encode().unwrap();
        l.handle_packet(Time::ZERO, &Packet::parse(&bytes).unwrap());
        let mut refused = Vec::new();
        while let Some(p) = l.poll_transmit() {
            let p = Packet::parse(&p).unwrap();
            if let Ok(e) = Event::decode(&p) {
                refused.push(e.text);
            }
        }
        refused
    }

    #[test]
    fn a_team_set_up_within_the_budget_and_ready_starts_the_match() {
        let mut l = lobby();
        assert!(!l.is_done(), "red is a person's and not ready yet");
        let setup = |squads: &str| PlayerCommand::Setup {
            team: "red".into(),
            squads: squads.into(),
            ready: false,
        };
        let ready = PlayerCommand::Ready {
            team: "red".into(),
            ready: true,
        };
        assert_eq!(
            say(&mut l, setup("a:tank+h5+p5,tank+h5+p5,scout")),
            ["red setup: team red costs 32 points; the budget is 30"]
        );
        assert_eq!(
            say(&mut l, setup("a:tank+h9")),
            ["red setup: \"tank+h9\": expected a robot type with +hN health and +pN power points, N 0 to 5 (e.g. tank+h2+p1)"]
        );
        assert_eq!(
            say(
                &mut l,
                PlayerCommand::Ready {
                    team: "blue".into(),
                    ready: false
                }
            ),
            ["blue: team blue is played by the built-in player"]
        );
        assert_eq!(
            l.setups()[0].to_string(),
            "alpha:tank,infantry",
            "refusals change nothing"
        );
        assert!(say(&mut l, setup("front:tank+h2+p1,scout+h1 back:amphibian")).is_empty());
        assert!(say(&mut l, ready).is_empty());
        assert!(l.is_done());
        let s = l.state();
        assert_eq!(s.status, LobbyStatus::Started);
        assert_eq!(s.teams[0].setup, "front:tank+h2+p1,scout+h1 back:amphibian");
        assert_eq!(s.teams[0].cost, 5 + 3 + 2 + 1 + 4);
        assert_eq!(s.kinds.len(), 4);
    }

    #[test]
    fn the_map_goes_out_during_the_pre_match_so_a_player_sees_it_while_choosing() {
        let mut l = lobby();
        let mut maps = 0;
        for k in 0..(2 * MAP_EVERY) {
            l.handle_timeout(Time::from_micros(k * 500_000));
            while let Some(p) = l.poll_transmit() {
                maps += usize::from(Packet::parse(&p).unwrap().has_subject(protocol::MAP));
            }
        }
        assert!(maps >= 2, "{maps} map packets in {} s", MAP_EVERY);
    }

    #[test]
    fn a_flood_of_packets_is_answered_with_a_lobby_every_tenth_of_a_second_not_one_each() {
        let mut l = lobby();
        l.handle_timeout(Time::ZERO);
        let mut lobbies = 0;
        for k in 0..1000u64 {
            let now = Time::from_micros(k * 1000);
            let c = PlayerCommand::Setup {
                team: "red".into(),
                squads: format!("alpha:tank+h{}", k % 5),
                ready: false,
            };
            let bytes = c.encode().unwrap();
            l.handle_packet(now, &Packet::parse(&bytes).unwrap());
            if l.poll_timeout().is_some_and(|t| t <= now) {
                l.handle_timeout(now);
            }
            while let Some(p) = l.poll_transmit() {
                lobbies += usize::from(Packet::parse(&p).unwrap().has_subject(protocol::LOBBY));
            }
        }
        // One at the start, then one per 100 ms of the second the flood lasted.
        assert!(
            (10..=12).contains(&lobbies),
            "{lobbies} lobby packets for 1000 packets in"
        );
    }
}
