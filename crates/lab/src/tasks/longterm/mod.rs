//! The loosely coupled experiment of section 6.2: seven agents (six robots
//! with different sensors and a desktop computer with an overhead camera), the
//! paper's four task types, tasks of random length introduced at random times
//! for hours, batteries and chargers, and failures injected at random.
//!
//! The robots are bodies in the physics field (discs the size of the paper's
//! Pioneers, in a 20 m room): they drive to where a task is, steering round
//! each other with their sonar, spend the task's length there, and drive to a
//! charger when their battery runs low (`bodies`). What is real is
//! everything MURDOCH does: every agent is an [`Agent`](colony_tasks::Agent) and the
//! user an [`UserAgent`](colony_tasks::UserAgent) exchanging the same packets as over
//! the hub, on the in-memory bus on simulated time. A run lasts exactly the
//! hours asked for; tasks still open then are counted as such.

pub mod bodies;
mod report;
mod run;
mod settings;

pub use report::{KindCounts, LogRow, LongtermOutcome, LongtermReport};
pub use run::{run, Longterm, LongtermError};
pub use settings::{
    roster, task_spec, AgentSpec, LongtermConfig, SettingsError, TaskKind, IMPOSSIBLE_TASK,
    PAPER_TASKS,
};
