//! NumPy buffers as Rust slices, checked once at the boundary: the shape the
//! environment expects, C order, and the element type (by the binding's type).
//! A wrong buffer is a `ValueError` naming it, never a panic or a silent reshape.

use numpy::{Element, PyReadonlyArrayDyn, PyReadwriteArrayDyn, PyUntypedArrayMethods};

/// Fortran order is contiguous too, and `as_slice` would take it: the values
/// would then be read in the wrong order, silently.
fn c_order<T, E>(is_c: bool, name: &str, slice: Result<T, E>) -> PyResult<T> {
    match (is_c, slice) {
        (true, Ok(s)) => Ok(s),
        (false, _) => Err(PyValueError::new_err(format!(
            "{name} is not a C-order contiguous array (np.ascontiguousarray makes one)"
        ))),
        (true, Err(_)) => Err(PyValueError::new_err(format!(
            "{name} is not an aligned array of its type (np.require(..., requirements=\"CA\") makes one)"
        ))),
    }
}
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
    c_order(a.is_c_contiguous(), name, a.as_slice())
}

/// The elements of a writable array of exactly `shape`, to fill in place.
pub fn write<'a, T: Element>(
    a: &'a mut PyReadwriteArrayDyn<'_, T>,
    name: &str,
    shape: &[usize],
) -> PyResult<&'a mut [T]> {
    check(name, a.shape(), shape)?;
    let is_c = a.is_c_contiguous();
    c_order(is_c, name, a.as_slice_mut())
}
