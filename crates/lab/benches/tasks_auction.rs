//! MURDOCH's costs, measured.
//!
//! 1. Over a real hub on loopback: the time from publishing an announcement to
//!    the award, with 10, 50 and 200 robot agents, each with its own UDP client
//!    (one thread multiplexes them with mio; the announcer has a thread of its
//!    own), and the messages each allocation takes. Every robot can do the task,
//!    so every auction hears every robot.
//! 2. On the in-memory bus: MURDOCH's greedy allocation against the optimal
//!    assignment (Kuhn-Munkres) on the same streams of tasks.
//!
//! `cargo bench -p colony-lab --bench tasks_auction` (add `-- --quick` for fewer rounds).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use colony_client::UdpClient;
use colony_hub::{HubConfig, Server};
use colony_lab::tasks::optimal::{compare, CompareConfig};
use colony_node::{Link, Mux};
use colony_tasks::{
    Agent, AgentConfig, AgentEvent, Announcer, AnnouncerEvent, AuctionConfig, TaskSpec, Time, Token,
};

fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let i = ((sorted.len() - 1) as f64 * p).round() as usize;
    sorted[i]
}

struct Row {
    robots: usize,
    rounds: usize,
    window_ms: u64,
    award: Vec<f64>,
    last_bid: Vec<f64>,
    bids: Vec<u32>,
    messages: Vec<u64>,
    reauctions: usize,
}

fn loopback(robots: usize, rounds: usize, window: Duration) -> Row {
    let mut server = Server::bind("127.0.0.1:0", HubConfig::default()).unwrap();
    let hub = server.local_addr().unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let s = stop.clone();
    let hub_thread = std::thread::spawn(move || server.run(&s));
    let epoch = Instant::now();
    let ready = Arc::new(AtomicBool::new(false));
    let (s, r) = (stop.clone(), ready.clone());
    let robot_thread = std::thread::spawn(move || {
        let mut mux = Mux::new().unwrap();
        for i in 0..robots {
            let link = Link::new(UdpClient::connect(hub).unwrap(), epoch);
            let mut a = Agent::new(
                Token::new(&format!("r{i:03}")).unwrap(),
                "mobile camera".parse().unwrap(),
                AgentConfig::default(),
                link.now(),
            );
            a.set_position(colony_proto::Vec2::new(i as f64, 0.0));
            mux.add(link, a).unwrap();
        }
        let settle = Instant::now() + Duration::from_millis(300);
        while !s.load(Ordering::Relaxed) {
            mux.pump().unwrap();
            let now = Time::from_micros(epoch.elapsed().as_micros() as u64);
            let mut any = false;
            for (_, _, a) in mux.iter_mut() {
                while let Some(e) = a.poll_event() {
                    if let AgentEvent::Start(_) = e {
                        a.finish(now);
                        any = true;
                    }
                }
            }
            if any {
                mux.pump_all().unwrap();
            }
            if Instant::now() > settle {
                r.store(true, Ordering::Relaxed);
            }
            mux.wait(Duration::from_millis(5)).unwrap();
        }
    });
    while !ready.load(Ordering::Relaxed) {
        std::thread::sleep(Duration::from_millis(10));
    }
    let mut link = Link::new(UdpClient::connect(hub).unwrap(), epoch);
    let mut user = Announcer::new(
        Token::new("bench").unwrap(),
        AuctionConfig {
            bid_window: window,
            ..AuctionConfig::default()
        },
    );
    let mut row = Row {
        robots,
        rounds,
        window_ms: window.as_millis() as u64,
        award: Vec::new(),
        last_bid: Vec::new(),
        bids: Vec::new(),
        messages: Vec::new(),
        reauctions: 0,
    };
    for _ in 0..rounds {
        let spec = TaskSpec::new("look", "camera mobile".parse().unwrap())
            .param("x", 0.0)
            .param("y", 0.0)
            .metric("distance", 1.0);
        let start = Instant::now();
        user.announce(link.now(), spec).unwrap();
        link.pump(&mut user).unwrap();
        let (mut awarded, mut last_bid, mut done) = (None, 0.0, false);
        let mut messages = 1u64; // the announcement
        while !done && start.elapsed() < Duration::from_secs(5) {
            link.wait(&user, Some(Duration::from_millis(2))).unwrap();
            link.pump(&mut user).unwrap();
            while let Some(e) = user.poll_event() {
                let ms = start.elapsed().as_secs_f64() * 1e3;
                match e {
                    AnnouncerEvent::Bid { .. } => {
                        last_bid = ms;
                        messages += 1;
                    }
                    AnnouncerEvent::Awarded { bids, .. } => {
                        // The first award is the one timed; a later one is a re-auction.
                        if awarded.is_none() {
                            awarded = Some((ms, bids));
                        } else {
                            row.reauctions += 1;
                        }
                        messages += 1;
                    }
                    AnnouncerEvent::Announced { attempt, .. } if attempt > 1 => messages += 1,
                    AnnouncerEvent::Started { .. } => messages += 1,
                    AnnouncerEvent::Completed { .. } => {
                        messages += 1;
                        done = true;
                    }
                    _ => {}
                }
            }
        }
        if let Some((ms, bids)) = awarded {
            row.award.push(ms);
            row.bids.push(bids);
            row.last_bid.push(last_bid);
            row.messages.push(messages);
        }
    }
    stop.store(true, Ordering::Relaxed);
    let _ = robot_thread.join();
    let _ = hub_thread.join();
    row.award.sort_by(f64::total_cmp);
    row.last_bid.sort_by(f64::total_cmp);
    row
}

fn main() {
    let quick = std::env::args().any(|a| a == "--quick");
    // `cargo test --benches` runs this with no extra flag; keep that short too.
    let in_test = std::env::args().any(|a| a == "--test" || a == "--nocapture");
    let rounds = if quick || in_test { 10 } else { 100 };
    let sizes: &[usize] = if in_test { &[10] } else { &[10, 50, 200] };
    println!("== announcement to award over a real hub on loopback");
    println!("robots  rounds  window_ms  award_p50_ms  award_p99_ms  last_bid_p50_ms  last_bid_p99_ms  bids_heard_min  bids_heard_mean  messages_per_allocation  reauctions");
    for &n in sizes {
        for window in [20, 50, 100].map(Duration::from_millis) {
            let r = loopback(n, rounds, window);
            println!(
                "{:>6}  {:>6}  {:>9}  {:>12.2}  {:>12.2}  {:>15.2}  {:>15.2}  {:>14}  {:>15.1}  {:>23.1}  {:>10}",
                r.robots,
                r.award.len(),
                r.window_ms,
                percentile(&r.award, 0.5),
                percentile(&r.award, 0.99),
                percentile(&r.last_bid, 0.5),
                percentile(&r.last_bid, 0.99),
                r.bids.iter().min().copied().unwrap_or(0),
                r.bids.iter().map(|&b| b as f64).sum::<f64>() / r.bids.len().max(1) as f64,
                r.messages.iter().sum::<u64>() as f64 / r.messages.len().max(1) as f64,
                r.reauctions
            );
            let _ = r.rounds;
        }
    }
    println!();
    println!("== greedy (MURDOCH) against optimal (Kuhn-Munkres), same streams, same metrics");
    println!("robots  tasks  metrics        seeds  greedy_tasks  optimal_tasks  ratio_mean  ratio_median  ratio_max  comparable_seeds");
    let seeds = if in_test { 3 } else { 30 };
    for (robots, tasks) in [(6, 6), (12, 10), (30, 30)] {
        for resources_term in [false, true] {
            let mut ratios = Vec::new();
            let (mut g, mut o) = (0, 0);
            for seed in 0..seeds {
                let c = compare(&CompareConfig {
                    seed,
                    robots,
                    tasks,
                    resources_term,
                })
                .unwrap();
                g += c.greedy_allocated;
                o += c.optimal_allocated;
                ratios.extend(c.cost_ratio());
            }
            ratios.sort_by(f64::total_cmp);
            println!(
                "{robots:>6}  {tasks:>5}  {:<13}  {seeds:>5}  {g:>12}  {o:>13}  {:>10.3}  {:>12.3}  {:>9.3}  {:>16}",
                if resources_term { "dist+batt+res" } else { "dist+batt" },
                ratios.iter().sum::<f64>() / ratios.len().max(1) as f64,
                percentile(&ratios, 0.5),
                ratios.last().copied().unwrap_or(f64::NAN),
                ratios.len()
            );
        }
    }
}
