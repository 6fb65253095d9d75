//! `packet_text` reads a message in little more memory than the message: a
//! forged one full of empty arrays must not become a tree of JSON values.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};

struct Counting;

static NOW: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            let now = NOW.fetch_add(layout.size(), Relaxed) + layout.size();
            PEAK.fetch_max(now, Relaxed);
        }
        p
    }
    unsafe fn dealloc(&self, p: *mut u8, layout: Layout) {
        unsafe { System.dealloc(p, layout) };
        NOW.fetch_sub(layout.size(), Relaxed);
    }
}

#[global_allocator]
static ALLOC: Counting = Counting;

#[test]
fn a_message_full_of_empty_arrays_takes_little_memory() {
    let mut json = b"{\"source\": \"x\", \"lines\": [".to_vec();
    for _ in 0..1_000_000 {
        json.extend_from_slice(b"[],");
    }
    json.extend_from_slice(b"[]], \"packet\": \"@ <a> 0\\n\"}");
    let before = NOW.load(Relaxed);
    PEAK.store(before, Relaxed);
    let got = colony_schema::packet_text(&json);
    let extra = PEAK.load(Relaxed) - before;
    assert_eq!(got, Some(("@ <a> 0\n".to_owned(), Some("x".to_owned()))));
    assert!(
        extra < json.len() / 10,
        "{extra} bytes to read a {}-byte message",
        json.len()
    );
}
