//! The sorting lab: trials and their files ([`experiment`]), statistics ([`stats`]), figures
//! ([`plot`]), the paper's reproduction ([`report`]) and its supplementary experiments
//! ([`supplementary`]), two reproductions compared ([`compare`]), and a live swarm launched
//! over a hub ([`launch`]). The controllers they run are colony-sort's.

pub mod compare;
pub mod experiment;
pub mod launch;
pub mod plot;
pub mod report;
pub mod stats;
pub mod supplementary;
