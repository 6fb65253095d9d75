//! `colony._native`: the Rust side of colony's Python package.
//!
//! Each class here is a thin skin over a Rust environment core
//! (`colony_env::sort`, `colony_env::game`): Python hands in NumPy buffers, the core
//! writes observations and rewards into them in place, and the GIL is released
//! while worlds step, so batched worlds use every core. The PettingZoo and
//! Gymnasium interfaces are Python (`python/colony`), where researchers read them.
#![forbid(unsafe_code)]

mod arrays;
mod game;
mod hub;
mod seeds;
mod sorting;

use pyo3::prelude::*;

/// The native module; `python/colony/_native.pyi` describes it for type checkers.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<hub::Publisher>()?;
    m.add_class::<sorting::SortConfig>()?;
    m.add_class::<sorting::SortCore>()?;
    m.add_class::<sorting::SortBatch>()?;
    m.add_class::<game::GameConfig>()?;
    m.add_class::<game::GameCore>()?;
    m.add_class::<game::GameBatch>()?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("MAX_RENDER_SIDE", colony_env::sort::MAX_RENDER_SIDE)?;
    Ok(())
}
