// What the `bridge_sample` fuzz target does with one input, shared with the
// corpus test in `crates/bridge/tests/fuzz_corpus.rs`. Returns whether the
// bridge would take the sample.
fn walk(data: &[u8]) -> bool {
    use colony_bridge::keys;
    let mut parts = data.splitn(3, |b| *b == 0);
    let key = String::from_utf8_lossy(parts.next().unwrap_or_default());
    let payload = parts.next().unwrap_or_default();
    let attachment = parts.next().unwrap_or_default();
    let _ = keys::parse_want_key(&key);
    let _ = colony_bridge::track::Stamp::from_bytes(attachment);
    match keys::read_sample(&key, payload) {
        Some((site, subjects)) => {
            assert_eq!(keys::parse_data_key(&key), Some((site.clone(), subjects.clone())));
            let packet = colony_wire::Packet::parse(payload).expect("a taken sample is a packet");
            assert_eq!(
                keys::data_key(&site, packet.subjects()),
                keys::data_key(&site, subjects.iter().map(|s| s.as_str())),
            );
            true
        }
        None => false,
    }
}
