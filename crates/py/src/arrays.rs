//! NumPy buffers as Rust slices, checked once at the boundary: the shape the
//! environment expects, C order, and the element type (by the binding's type).
//! A wrong buffer is a `ValueError` naming it, never a panic or a silent reshape.

use numpy::{Element, PyReadonlyArrayDyn, PyReadwriteArrayDyn, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::PyResult;

fn check(name: &str, got: &[usize], want: &[usize]) -> PyResult<()> {
    if got != want {
        return Err(PyValueError::new_err(format!(
            "{name} has shape {got:?}, expected {want:?}"
        )));
    }
    Ok(())
}

/// The elements of a read-only array of exactly `shape`.
pub fn read<'a, T: Element>(
    a: &'a PyReadonlyArrayDyn<'_, T>,
    name: &str,
    shape: &[usize],
) -> PyResult<&'a [T]> {
    check(name, a.shape(), shape)?;
    a.as_slice()
        .map_err(|_| PyValueError::new_err(format!("{name} is not a contiguous C-order array")))
}

/// The elements of a writable array of exactly `shape`, to fill in place.
pub fn write<'a, T: Element>(
    a: &'a mut PyReadwriteArrayDyn<'_, T>,
    name: &str,
    shape: &[usize],
) -> PyResult<&'a mut [T]> {
    check(name, a.shape(), shape)?;
    a.as_slice_mut()
        .map_err(|_| PyValueError::new_err(format!("{name} is not a contiguous C-order array")))
}
