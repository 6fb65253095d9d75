//! Bidding: score an announcement, bid, and on winning acknowledge and start
//! (or decline when something else came first).

use colony_wire::seal::Binding;
use colony_wire::Subject;

use super::{Agent, AgentEvent, AgentMode, Job, Pending};
use crate::metric::RobotView;
use crate::protocol::{Announcement, Bid, Negotiation};
use colony_node::Time;

impl Agent {
    /// Withdraws every open bid.
    pub(super) fn decline_all(&mut self) {
        for (subject, p) in std::mem::take(&mut self.pending) {
            self.send(
                &subject,
                &Negotiation::Decline {
                    task: p.ann.id,
                    bidder: self.id.clone(),
                },
            );
        }
    }

    /// Hears a task: bids for it if it is free, capable, charged enough and
    /// can score it.
    pub(super) fn on_announce(&mut self, now: Time, ann: Announcement, announcer: Binding) {
        if self.mode != AgentMode::Idle
            || !ann.spec.resources.is_subset(&self.resources)
            || self.pending.contains_key(&ann.negotiation)
        {
            return;
        }
        let skip = |why: String| AgentEvent::Skipped {
            task: ann.id,
            name: ann.spec.name.clone(),
            why,
        };
        let needed = ann.spec.length_s * self.config.drain_per_second;
        if self.config.drain_per_second > 0.0 && self.battery - needed < self.config.low_battery {
            let e = skip(format!(
                "battery {:.2} would fall below {:.2} during a {} s task",
                self.battery, self.config.low_battery, ann.spec.length_s
            ));
            self.push_event(e);
            return;
        }
        let view = RobotView {
            position: self.position,
            heading: self.heading,
            battery: self.battery,
            resources: &self.resources,
        };
        let score = match self.metrics.score(&ann.spec, &view) {
            // A score outside what the task's metrics can add up to would be
            // taken for a forgery by every listener.
            Ok(s) if !ann.spec.admits_score(s) => {
                let e = skip(format!(
                    "score {s} is outside what its metrics can add up to"
                ));
                self.push_event(e);
                return;
            }
            Ok(s) => s,
            Err(e) => {
                let e = skip(e.to_string());
                self.push_event(e);
                return;
            }
        };
        let bid = Bid {
            task: ann.id,
            bidder: self.id.clone(),
            score,
        };
        self.stats.bids += 1;
        let subject = ann.negotiation.clone();
        self.send(&subject, &Negotiation::Bid(bid.clone()));
        self.pending.insert(
            subject,
            Pending {
                close_at: now + ann.deadline + self.config.award_grace,
                ann,
                announcer,
                best: bid,
            },
        );
        self.refresh_subs();
    }

    /// Won: acknowledge and start, or decline if something else came first.
    pub(super) fn take(&mut self, now: Time, subject: Subject) {
        let Some(p) = self.pending.remove(&subject) else {
            return;
        };
        if self.mode != AgentMode::Idle {
            let decline = Negotiation::Decline {
                task: p.ann.id,
                bidder: self.id.clone(),
            };
            self.send(&subject, &decline);
            self.refresh_subs();
            return;
        }
        let ack = Negotiation::Ack {
            task: p.ann.id,
            bidder: self.id.clone(),
        };
        self.send(&subject, &ack);
        // One task at a time: withdraw every other bid so those auctions need not wait.
        self.decline_all();
        self.mode = AgentMode::Working;
        self.stats.started += 1;
        self.job = Some(Job {
            ann: p.ann.clone(),
            announcer: p.announcer,
            last_heard: now,
            next_renew: now + self.config.renew_interval,
            progress: 0.0,
        });
        self.push_event(AgentEvent::Start(p.ann));
        self.refresh_subs();
        self.report(now);
    }
}
