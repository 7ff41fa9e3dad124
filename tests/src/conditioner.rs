//! A UDP link conditioner: a proxy on loopback that sits between real
//! clients and a real server and delays, jitters, drops (independently or in
//! bursts), reorders and duplicates datagrams, both ways. The kernel here
//! has no `netem`, so this is how the end-to-end tests see a bad network.
//!
//! Clients send to [`Conditioner::addr`]; each client address gets its own
//! upstream socket towards the server, so the server sees one peer per
//! client, as behind a NAT.

use std::collections::HashMap;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use inertia_protocol::rng::SplitMix;
use tokio::net::UdpSocket;
use tokio::task::JoinHandle;

/// Loss that comes in bursts: a two-state (Gilbert–Elliott) channel that
/// moves from good to bad with `enter` per datagram and back with `leave`;
/// in the bad state each datagram is lost with `loss_bad`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BurstLoss {
    /// Probability per datagram of entering the bad state.
    pub enter: f64,
    /// Probability per datagram of leaving it.
    pub leave: f64,
    /// Loss probability while bad.
    pub loss_bad: f64,
}

/// What happens to datagrams going one way.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Impairment {
    /// Fixed one-way delay.
    pub delay: Duration,
    /// Each datagram's delay varies uniformly within ± this.
    pub jitter: Duration,
    /// Probability each datagram is lost (independent of bursts).
    pub loss: f64,
    /// Burst loss on top of `loss`.
    pub burst: Option<BurstLoss>,
    /// Probability a datagram is held back an extra `delay + jitter`, so
    /// it arrives after later ones.
    pub reorder: f64,
    /// Probability a datagram is delivered twice.
    pub duplicate: f64,
}

impl Impairment {
    /// Half of a round trip of `rtt` with ± `jitter` and `loss`, the usual
    /// test link.
    pub fn half_rtt(rtt: Duration, jitter: Duration, loss: f64) -> Self {
        Impairment {
            delay: rtt / 2,
            jitter,
            loss,
            ..Default::default()
        }
    }
}

/// Counters of what the conditioner did, both ways together.
#[derive(Debug, Default)]
pub struct ConditionerStats {
    /// Datagrams received from either side.
    pub received: AtomicU64,
    /// Datagrams dropped.
    pub dropped: AtomicU64,
    /// Extra copies sent.
    pub duplicated: AtomicU64,
    /// Datagrams held back to arrive out of order.
    pub reordered: AtomicU64,
}

struct Direction {
    impairment: Impairment,
    rng: SplitMix,
    bad: bool,
}

impl Direction {
    /// The delays at which to deliver one datagram: none if lost, two if
    /// duplicated.
    fn schedule(&mut self, stats: &ConditionerStats) -> Vec<Duration> {
        let imp = self.impairment;
        stats.received.fetch_add(1, Ordering::Relaxed);
        if let Some(b) = imp.burst {
            let flip = if self.bad { b.leave } else { b.enter };
            if self.rng.uniform() < flip {
                self.bad = !self.bad;
            }
            if self.bad && self.rng.uniform() < b.loss_bad {
                stats.dropped.fetch_add(1, Ordering::Relaxed);
                return Vec::new();
            }
        }
        if self.rng.uniform() < imp.loss {
            stats.dropped.fetch_add(1, Ordering::Relaxed);
            return Vec::new();
        }
        let copies = if self.rng.uniform() < imp.duplicate {
            stats.duplicated.fetch_add(1, Ordering::Relaxed);
            2
        } else {
            1
        };
        (0..copies)
            .map(|_| {
                let jitter = imp.jitter.as_secs_f64() * (2.0 * self.rng.uniform() - 1.0);
                let mut delay = (imp.delay.as_secs_f64() + jitter).max(0.0);
                if self.rng.uniform() < imp.reorder {
                    stats.reordered.fetch_add(1, Ordering::Relaxed);
                    delay += imp.delay.as_secs_f64() + imp.jitter.as_secs_f64();
                }
                Duration::from_secs_f64(delay)
            })
            .collect()
    }
}

/// A running conditioner. Dropping it stops the proxy.
pub struct Conditioner {
    addr: SocketAddr,
    stats: Arc<ConditionerStats>,
    to_server: Arc<Mutex<Direction>>,
    to_client: Arc<Mutex<Direction>>,
    tasks: Arc<Mutex<Vec<JoinHandle<()>>>>,
}

impl std::fmt::Debug for Conditioner {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Conditioner")
            .field("addr", &self.addr)
            .finish()
    }
}

impl Conditioner {
    /// Starts a conditioner on a free loopback port in front of `server`,
    /// with `to_server` applied to client → server datagrams and
    /// `to_client` to the replies. `seed` makes the impairments repeatable
    /// (the timing of the real sockets still varies).
    pub async fn start(
        server: SocketAddr,
        to_server: Impairment,
        to_client: Impairment,
        seed: u64,
    ) -> std::io::Result<Conditioner> {
        let front = Arc::new(UdpSocket::bind("127.0.0.1:0").await?);
        let addr = front.local_addr()?;
        let stats = Arc::new(ConditionerStats::default());
        let dir = |impairment, seed| {
            Arc::new(Mutex::new(Direction {
                impairment,
                rng: SplitMix(seed),
                bad: false,
            }))
        };
        let to_server = dir(to_server, seed);
        let to_client = dir(to_client, seed ^ 0x5EED_5EED_5EED_5EED);
        let tasks = Arc::new(Mutex::new(Vec::new()));
        let main = tokio::spawn(run_front(
            front,
            server,
            stats.clone(),
            to_server.clone(),
            to_client.clone(),
            tasks.clone(),
        ));
        tasks.lock().expect("tasks lock").push(main);
        Ok(Conditioner {
            addr,
            stats,
            to_server,
            to_client,
            tasks,
        })
    }

    /// The address clients should send to.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// What the conditioner has done so far.
    pub fn stats(&self) -> &ConditionerStats {
        &self.stats
    }

    /// Changes the impairments from now on.
    pub fn set(&self, to_server: Impairment, to_client: Impairment) {
        self.to_server.lock().expect("direction lock").impairment = to_server;
        self.to_client.lock().expect("direction lock").impairment = to_client;
    }
}

impl Drop for Conditioner {
    fn drop(&mut self) {
        for task in self.tasks.lock().expect("tasks lock").drain(..) {
            task.abort();
        }
    }
}

/// Sends `bytes` to `to` through `socket` after each of `delays`.
fn deliver(socket: &Arc<UdpSocket>, to: Option<SocketAddr>, bytes: &[u8], delays: Vec<Duration>) {
    for delay in delays {
        let socket = socket.clone();
        let bytes = bytes.to_vec();
        tokio::spawn(async move {
            tokio::time::sleep(delay).await;
            let _ = match to {
                Some(to) => socket.send_to(&bytes, to).await,
                None => socket.send(&bytes).await,
            };
        });
    }
}

async fn run_front(
    front: Arc<UdpSocket>,
    server: SocketAddr,
    stats: Arc<ConditionerStats>,
    to_server: Arc<Mutex<Direction>>,
    to_client: Arc<Mutex<Direction>>,
    tasks: Arc<Mutex<Vec<JoinHandle<()>>>>,
) {
    let mut upstream: HashMap<SocketAddr, Arc<UdpSocket>> = HashMap::new();
    let mut buf = vec![0u8; 65_536];
    loop {
        let Ok((n, client)) = front.recv_from(&mut buf).await else {
            continue;
        };
        let back = match upstream.get(&client) {
            Some(back) => back.clone(),
            None => {
                let Ok(back) = UdpSocket::bind("127.0.0.1:0").await else {
                    continue;
                };
                if back.connect(server).await.is_err() {
                    continue;
                }
                let back = Arc::new(back);
                upstream.insert(client, back.clone());
                let task = tokio::spawn(run_back(
                    back.clone(),
                    front.clone(),
                    client,
                    stats.clone(),
                    to_client.clone(),
                ));
                tasks.lock().expect("tasks lock").push(task);
                back
            }
        };
        let delays = to_server.lock().expect("direction lock").schedule(&stats);
        deliver(&back, None, &buf[..n], delays);
    }
}

async fn run_back(
    back: Arc<UdpSocket>,
    front: Arc<UdpSocket>,
    client: SocketAddr,
    stats: Arc<ConditionerStats>,
    to_client: Arc<Mutex<Direction>>,
) {
    let mut buf = vec![0u8; 65_536];
    loop {
        let Ok(n) = back.recv(&mut buf).await else {
            continue;
        };
        let delays = to_client.lock().expect("direction lock").schedule(&stats);
        deliver(&front, Some(client), &buf[..n], delays);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test]
    async fn delays_drops_and_duplicates_as_configured() {
        let server = UdpSocket::bind("127.0.0.1:0").await.unwrap();
        let server_addr = server.local_addr().unwrap();
        let imp = Impairment {
            delay: Duration::from_millis(20),
            jitter: Duration::from_millis(5),
            loss: 0.2,
            duplicate: 0.1,
            ..Default::default()
        };
        let cond = Conditioner::start(server_addr, imp, Impairment::default(), 7)
            .await
            .unwrap();
        let client = UdpSocket::bind("127.0.0.1:0").await.unwrap();
        let start = tokio::time::Instant::now();
        for i in 0..500u32 {
            client.send_to(&i.to_le_bytes(), cond.addr()).await.unwrap();
        }
        let mut got = 0;
        let mut buf = [0u8; 16];
        let mut first = None;
        while let Ok(Ok((n, _))) =
            tokio::time::timeout(Duration::from_millis(300), server.recv_from(&mut buf)).await
        {
            assert_eq!(n, 4);
            first.get_or_insert(start.elapsed());
            got += 1;
        }
        assert!(first.unwrap() >= Duration::from_millis(14), "{first:?}");
        // 500 × 0.8 × 1.1 = 440 expected.
        assert!((380..=500).contains(&got), "{got} delivered");
        assert_eq!(cond.stats().received.load(Ordering::Relaxed), 500);
        let dropped = cond.stats().dropped.load(Ordering::Relaxed);
        assert!((60..=140).contains(&dropped), "{dropped} dropped");
    }

    #[test]
    fn bursts_cluster_losses() {
        let stats = ConditionerStats::default();
        let mut d = Direction {
            impairment: Impairment {
                burst: Some(BurstLoss {
                    enter: 0.02,
                    leave: 0.25,
                    loss_bad: 1.0,
                }),
                ..Default::default()
            },
            rng: SplitMix(3),
            bad: false,
        };
        let lost: Vec<bool> = (0..20_000).map(|_| d.schedule(&stats).is_empty()).collect();
        let losses = lost.iter().filter(|&&l| l).count();
        let runs = lost.windows(2).filter(|w| !w[0] && w[1]).count();
        // Stationary bad share 0.02 / 0.27 ≈ 7.4 %, mean burst 4 datagrams.
        assert!((1000..2000).contains(&losses), "{losses}");
        let mean_burst = losses as f64 / runs as f64;
        assert!((3.0..5.5).contains(&mean_burst), "{mean_burst}");
    }
}
