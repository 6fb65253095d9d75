//! A robot's word about itself, for whoever watches the auctions (the
//! monitor's task board): its mode, battery, resources and task. No auction
//! depends on it; agents say it about once a second and whenever it changes.

use colony_wire::{Line, PacketBuilder, Priority};

use super::error::{unwritable, EncodeError};
use super::{ResourceSet, Token};
use crate::fields::{self, clip, valid_subject_name as valid_name};
use crate::table::{int, line, num, text, MessageTable};
use crate::DecodeError;

/// The channel robots report on.
pub const ROBOTS: &str = "murdoch.robots";

/// What a robot's report holds.
pub const TABLE: MessageTable = MessageTable {
    channel: ROBOTS,
    lines: &[line(
        "robot",
        &[
            text("name"),
            text("mode"),
            num("battery"),
            text("resources"),
            int("task").optional(),
            text("task_name").with("task"),
        ],
    )],
};

/// What a robot is doing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RobotMode {
    /// Listening for announcements it can serve.
    Idle,
    /// Executing a task.
    Working,
    /// Charging: deaf to every announcement until full.
    Charging,
}

impl RobotMode {
    /// Its name in a report.
    pub fn as_str(self) -> &'static str {
        match self {
            RobotMode::Idle => "idle",
            RobotMode::Working => "working",
            RobotMode::Charging => "charging",
        }
    }
}

/// `robot`: one robot's report.
///
/// ```text
/// @ <murdoch.robots> 0
/// robot name r2 mode working battery 0.82 resources "camera laser mobile" task 17 task_name sentry-duty
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct RobotReport {
    /// The robot's token, as its bids carry it.
    pub name: Token,
    /// What it is doing.
    pub mode: RobotMode,
    /// Its charge, 0 to 1.
    pub battery: f64,
    /// What it has now.
    pub resources: ResourceSet,
    /// The task it executes (its number and name), if any.
    pub task: Option<(u64, String)>,
}

impl RobotReport {
    /// The packet on [`ROBOTS`].
    pub fn encode(&self) -> Result<Vec<u8>, EncodeError> {
        if !(0.0..=1.0).contains(&self.battery) {
            return Err(unwritable(
                "battery",
                format!("{} is not between 0 and 1", self.battery),
            ));
        }
        let mut p = PacketBuilder::new([ROBOTS], Priority(0));
        let mut l = p.line("robot");
        l.bare("name", self.name.as_str())
            .bare("mode", self.mode.as_str())
            .field("battery", self.battery)
            .field("resources", resource_names(&self.resources).as_str());
        if let Some((id, name)) = &self.task {
            fields::writable_task_number("task", *id)?;
            if !valid_name(name) {
                return Err(unwritable("task_name", format!("`{name}` is not a name")));
            }
            l.field("task", *id).bare("task_name", name);
        }
        Ok(p.finish()?)
    }

    /// Reads a `robot` line.
    pub(crate) fn decode_line(line: &Line<'_>) -> Result<RobotReport, DecodeError> {
        let mode = match line.str("mode")?.as_ref() {
            "idle" => RobotMode::Idle,
            "working" => RobotMode::Working,
            "charging" => RobotMode::Charging,
            other => {
                return Err(fields::bad_field(
                    line,
                    "mode",
                    format!("`{}` is not idle, working or charging", clip(other)),
                ))
            }
        };
        let resources = line
            .str("resources")?
            .parse::<ResourceSet>()
            .map_err(|e| fields::bad_field(line, "resources", e.to_string()))?;
        let task = match line.get("task") {
            Some(_) => Some((
                fields::task_number(line, "task")?,
                fields::subject_name(line, "task_name")?,
            )),
            None => None,
        };
        Ok(RobotReport {
            name: fields::token(line, "name")?,
            mode,
            battery: fields::fraction(line, "battery")?,
            resources,
            task,
        })
    }
}

/// The set's names, separated by blanks (as [`ResourceSet`] reads them back).
fn resource_names(set: &ResourceSet) -> String {
    let names: Vec<&str> = set.iter().map(|s| s.as_str()).collect();
    names.join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::murdoch::Message;

    fn report(task: Option<(u64, &str)>) -> RobotReport {
        RobotReport {
            name: Token::new("r2").unwrap(),
            mode: RobotMode::Working,
            battery: 0.82,
            resources: "camera laser".parse().unwrap(),
            task: task.map(|(id, n)| (id, n.to_owned())),
        }
    }

    #[test]
    fn a_report_writes_the_documented_text_and_reads_back() {
        let r = report(Some((17, "sentry-duty")));
        let bytes = r.encode().unwrap();
        assert_eq!(
            std::str::from_utf8(&bytes).unwrap(),
            "@ <murdoch.robots> 0\nrobot name r2 mode working battery 0.82 resources \"camera laser\" task 17 task_name sentry-duty\n"
        );
        assert_eq!(Message::decode_bytes(&bytes).unwrap(), Message::Robot(r));
        let idle = report(None);
        assert_eq!(
            Message::decode_bytes(&idle.encode().unwrap()).unwrap(),
            Message::Robot(idle)
        );
    }

    #[test]
    fn the_table_is_what_the_writer_writes_and_the_reader_needs() {
        let samples = [
            report(Some((17, "sentry-duty"))).encode().unwrap(),
            report(None).encode().unwrap(),
        ];
        crate::table::check::codec(&TABLE, &samples, |p| {
            matches!(Message::decode(p), Ok(Message::Robot(_)))
        });
    }

    #[test]
    fn a_bad_report_is_refused_with_its_field() {
        for (text, field) in [
            (
                "robot name r2 mode dancing battery 1 resources \"\"",
                "mode",
            ),
            (
                "robot name r2 mode idle battery 1.5 resources \"\"",
                "battery",
            ),
            (
                "robot name r2 mode idle battery 1 resources \"a b!\"",
                "resources",
            ),
            (
                "robot name r2 mode idle battery 1 resources \"\" task -1 task_name x",
                "task",
            ),
            (
                "robot name r2 mode idle battery 1 resources \"\" task 1",
                "task_name",
            ),
        ] {
            let packet = format!("@ <murdoch.robots> 0\n{text}\n");
            let e = Message::decode_bytes(packet.as_bytes()).unwrap_err();
            assert!(e.to_string().contains(field), "{text}: {e}");
        }
        // A report belongs on its own channel.
        let elsewhere =
            "@ <murdoch.user.1.1> 0\nrobot name r2 mode idle battery 1 resources \"\"\n";
        assert!(Message::decode_bytes(elsewhere.as_bytes()).is_err());
    }

    #[test]
    fn an_unwritable_report_is_refused_before_it_is_sent() {
        let mut r = report(Some((1, "x y")));
        assert!(r.encode().is_err());
        r.task = None;
        r.battery = f64::NAN;
        assert!(r.encode().is_err());
    }
}
