//! What a seal costs: sealing a MURDOCH-sized packet (one Ed25519 signature)
//! and opening it (one strict verification), against the shared-key `auth`
//! line's HMAC for the same packet.
//!
//! `cargo bench -p colony-wire --bench seal`

use std::hint::black_box;
use std::time::{Duration, SystemTime};

use colony_wire::auth::{Key, Signer};
use colony_wire::seal::{self, Identity};
use criterion::{criterion_group, criterion_main, Criterion};

const PACKET: &[u8] = b"@ <murdoch.user.17.1> 0\nrenew task 17 by r2 progress 0.4\n";

fn seal_and_open(c: &mut Criterion) {
    let mut g = c.benchmark_group("seal");
    g.measurement_time(Duration::from_secs(3));
    let mut id = Identity::from_seed([7; 32]);
    g.bench_function("seal", |b| b.iter(|| id.sealed(black_box(PACKET).to_vec())));
    let sealed = id.sealed(PACKET.to_vec());
    g.bench_function("open", |b| {
        b.iter(|| seal::open(black_box(&sealed)).unwrap())
    });
    let key = Key::new(b"a shared key of thirty-two bytes").unwrap();
    let mut signer = Signer::new(key.clone());
    g.bench_function("auth sign", |b| {
        b.iter(|| {
            let mut p = black_box(PACKET).to_vec();
            signer.sign(&mut p, SystemTime::now());
            p
        })
    });
    let mut signed = PACKET.to_vec();
    Signer::new(key.clone()).sign(&mut signed, SystemTime::now());
    g.bench_function("auth verify", |b| {
        b.iter(|| key.verify(black_box(&signed)).unwrap())
    });
    g.finish();
}

criterion_group!(benches, seal_and_open);
criterion_main!(benches);
