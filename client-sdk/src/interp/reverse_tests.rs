//! The buffer on a simulated link: reverse play, pauses around it, reordering with and without sequence numbers, and a game drawing at a low frame rate.

//! Reverse play on a virtual clock: a 60 Hz server moves a body round a
//! circle (radius 2 m, 5 m/s) and sends 30 Hz snapshots over a link
//! with 50 ms ± 10 ms delay and 5 % loss (optionally 5 % held back a
//! further 30–50 ms); it plays forwards, then history backwards at
//! speed 1 (time scale −1, ticks decreasing, sequence numbers still
//! increasing), then forwards again. The client samples at 144 Hz.

use super::*;

const HZ: f64 = 60.0;
const RADIUS: f64 = 2.0;
const OMEGA: f64 = 2.5;
const SPEED: f64 = RADIUS * OMEGA;
const FRAME: f64 = 1.0 / 144.0;
const STEP: f64 = 0.00025;
const LOCAL_OFFSET: f64 = 300.0;

fn truth(tick: f64) -> DVec3 {
    let a = OMEGA * tick / HZ;
    DVec3::new(RADIUS * a.cos(), 1.0, RADIUS * a.sin())
}

/// The recorded state at a tick: the same whichever way it is played
/// (velocities are d(position)/d(simulation time)).
fn view(tick: u64) -> ViewEntity {
    let a = OMEGA * tick as f64 / HZ;
    ViewEntity {
        id: 1,
        position: truth(tick as f64),
        rotation: DQuat::from_rotation_y(-a),
        linear_velocity: Some(DVec3::new(-SPEED * a.sin(), 0.0, SPEED * a.cos())),
        angular_velocity: Some(DVec3::new(0.0, -OMEGA, 0.0)),
        at_rest: false,
    }
}

struct Rng(u64);

impl Rng {
    fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

#[derive(Debug, Clone, Copy)]
enum Action {
    /// Play at this time scale (negative: backwards).
    Play(f64),
    /// Stop (time scale 0, paused).
    Pause,
    Seek(u64),
}

#[derive(Debug, Clone, Copy)]
struct Rendered {
    wall: f64,
    tick: f64,
    position: DVec3,
    /// The newest tick arrived, and the server's own tick, then.
    newest: f64,
    server_tick: f64,
}

struct Sim {
    buffer: InterpolationBuffer,
    with_seq: bool,
    reorder: bool,
    rng: Rng,
    tick: u64,
    acc: f64,
    scale: f64,
    paused: bool,
    seq: u16,
    next_send: f64,
    in_flight: Vec<(f64, Sent)>,
    next_frame: f64,
    /// Local time between two samples, s (the game's frame interval).
    frame_interval: f64,
    wall: f64,
    frames: Vec<Rendered>,
    events: Vec<(f64, InterpEvent)>,
    observed_cuts: usize,
}

impl Sim {
    fn new(with_seq: bool, reorder: bool, seed: u64) -> Self {
        Self {
            buffer: InterpolationBuffer::new(HZ),
            with_seq,
            reorder,
            rng: Rng(seed),
            tick: 1000,
            acc: 0.0,
            scale: 1.0,
            paused: false,
            seq: 65_400,
            next_send: 0.001,
            in_flight: Vec::new(),
            next_frame: 0.0,
            frame_interval: FRAME,
            wall: 0.0,
            frames: Vec::new(),
            events: Vec::new(),
            observed_cuts: 0,
        }
    }

    fn run(&mut self, end: f64, script: &[(f64, Action)]) {
        let mut script = script.iter().peekable();
        while self.wall < end {
            self.wall += STEP;
            let wall = self.wall;
            while let Some(&&(at, action)) = script.peek() {
                if at > wall {
                    break;
                }
                match action {
                    Action::Play(s) => {
                        self.scale = s;
                        self.paused = false;
                    }
                    Action::Pause => self.paused = true,
                    Action::Seek(t) => {
                        self.tick = t;
                        self.acc = 0.0;
                    }
                }
                script.next();
            }
            // Ticks due, forwards or (reverse play) backwards.
            if !self.paused {
                self.acc += STEP * self.scale.abs();
            }
            while self.acc >= 1.0 / HZ {
                self.acc -= 1.0 / HZ;
                if self.scale < 0.0 {
                    self.tick -= 1;
                } else {
                    self.tick += 1;
                }
            }
            if wall >= self.next_send {
                self.next_send += 1.0 / 30.0;
                self.send(wall);
            }
            self.in_flight.sort_by(|a, b| b.0.total_cmp(&a.0));
            while self.in_flight.last().is_some_and(|p| p.0 <= wall) {
                let (at, snapshot) = self.in_flight.pop().unwrap();
                let obs = push(&mut self.buffer, at + LOCAL_OFFSET, snapshot);
                self.observed_cuts += usize::from(matches!(obs, Observation::Discontinuity(_)));
            }
            if wall >= self.next_frame {
                self.next_frame += self.frame_interval;
                let newest = self.buffer.clock().newest_tick().map_or(0.0, |n| n as f64);
                let frame = self.buffer.sample(wall + LOCAL_OFFSET);
                if let Some(e) = frame.get(1) {
                    self.frames.push(Rendered {
                        wall,
                        tick: frame.render_tick,
                        position: e.position,
                        newest,
                        server_tick: self.tick as f64,
                    });
                }
                while let Some(ev) = self.buffer.poll_event() {
                    self.events.push((wall, ev));
                }
            }
        }
    }

    fn send(&mut self, wall: f64) {
        self.seq = self.seq.wrapping_add(1);
        let snapshot = Sent {
            meta: SnapshotMeta {
                seq: self.with_seq.then_some(self.seq),
                tick: self.tick,
                time_scale: if self.paused { 0.0 } else { self.scale as f32 },
                paused: self.paused,
            },
            entities: vec![view(self.tick)],
        };
        if self.rng.uniform() < 0.05 {
            return;
        }
        let mut delay = 0.05 + (self.rng.uniform() * 2.0 - 1.0) * 0.01;
        if self.reorder && self.rng.uniform() < 0.05 {
            delay += 0.03 + 0.02 * self.rng.uniform();
        }
        self.in_flight.push((wall + delay, snapshot));
    }

    fn between(&self, from: f64, to: f64) -> Vec<Rendered> {
        self.frames
            .iter()
            .copied()
            .filter(|f| (from..to).contains(&f.wall))
            .collect()
    }
}

fn error(f: &Rendered) -> f64 {
    (f.position - truth(f.tick)).length()
}

fn percentile(mut v: Vec<f64>, p: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * p).round() as usize]
}

fn largest_step(frames: &[Rendered]) -> f64 {
    frames
        .windows(2)
        .map(|w| (w[1].position - w[0].position).length())
        .fold(0.0, f64::max)
}

#[test]
fn issue_15_a_game_drawing_at_10_frames_a_second_stays_behind_the_newest_snapshot() {
    // A frame (0.1 s) longer than the render delay: the catch-up taken
    // as one long step used to overshoot the arrival edge and run on
    // past the newest snapshot, extrapolating every other frame.
    for frame_interval in [0.1, 1.0 / 15.0, 1.0 / 30.0] {
        let mut sim = Sim::new(true, false, 7);
        sim.frame_interval = frame_interval;
        sim.run(10.0, &[]);
        let frames = sim.between(3.0, 10.0);
        assert!(frames.len() as f64 > 6.0 / frame_interval);
        let ahead = frames.iter().filter(|f| f.tick > f.newest).count();
        assert_eq!(
            ahead,
            0,
            "{ahead} of {} frames at {frame_interval:.3} s drawn past the newest snapshot",
            frames.len()
        );
        // Steady: each frame moves the picture on by about a frame of ticks.
        let per_frame = HZ * frame_interval;
        for w in frames.windows(2) {
            let step = w[1].tick - w[0].tick;
            assert!(
                (step - per_frame).abs() < 0.35 * per_frame,
                "a step of {step:.2} ticks at {:.2} s (a frame is {per_frame:.2})",
                w[1].wall
            );
        }
    }
}

/// Forwards to 4 s, backwards at speed 1 to 10 s, forwards to 14 s.
fn forward_reverse_forward(with_seq: bool, reorder: bool, seed: u64) {
    let mut sim = Sim::new(with_seq, reorder, seed);
    sim.run(
        14.0,
        &[(4.0, Action::Play(-1.0)), (10.0, Action::Play(1.0))],
    );
    let stats = sim.buffer.stats();
    assert!(sim.events.is_empty(), "{:?}", sim.events);
    assert_eq!(sim.observed_cuts, 0);
    assert_eq!(stats.discontinuities, 0, "{stats:?}");
    assert_eq!(stats.stalls, 0, "{stats:?}");

    // Backwards, once the turn has come through the delay: the render
    // tick only goes down, at about 60 ticks/s.
    let reverse = sim.between(4.5, 10.0);
    assert!(reverse.len() > 700);
    for w in reverse.windows(2) {
        assert!(
            w[1].tick < w[0].tick,
            "render tick went from {} to {} at {:.3} s",
            w[0].tick,
            w[1].tick,
            w[1].wall
        );
    }
    let rate = (reverse[reverse.len() - 1].tick - reverse[0].tick)
        / (reverse[reverse.len() - 1].wall - reverse[0].wall);
    assert!((rate + HZ).abs() < 1.0, "rate {rate} ticks/s in reverse");
    // Forwards again afterwards, and before.
    for part in [sim.between(1.0, 4.0), sim.between(10.5, 14.0)] {
        for w in part.windows(2) {
            assert!(w[1].tick >= w[0].tick, "at {:.3} s", w[1].wall);
        }
    }
    // The render delay is kept in the direction of play: in reverse
    // the render tick is above the newest tick arrived (by about the
    // delay) and never far from the server's own.
    let behind: Vec<f64> = reverse.iter().map(|f| (f.tick - f.newest) / HZ).collect();
    let behind_median = percentile(behind.clone(), 0.5);
    let behind_min = percentile(behind, 0.0);
    assert!(
        (0.03..0.15).contains(&behind_median) && behind_min > -0.1,
        "behind the newest: median {behind_median} s, least {behind_min} s"
    );
    let lag = reverse
        .iter()
        .map(|f| (f.tick - f.server_tick) / HZ)
        .fold(f64::NEG_INFINITY, f64::max);
    assert!(lag > 0.0 && lag < 0.25, "render lag {lag} s");
    let newest = sim.buffer.clock().newest_tick().unwrap() as f64;
    assert!(sim.buffer.render_tick().unwrap() < newest);

    // Accurate throughout, turns included, and no pops.
    let settled = sim.between(1.0, 14.0);
    let errors: Vec<f64> = settled.iter().map(error).collect();
    let p99 = percentile(errors.clone(), 0.99);
    let max = percentile(errors, 1.0);
    let reverse_p99 = percentile(reverse.iter().map(error).collect(), 0.99);
    let step = largest_step(&settled);
    let turns: Vec<(f64, f64)> = sim
        .frames
        .windows(3)
        .filter(|w| (w[1].tick - w[0].tick) * (w[2].tick - w[1].tick) < 0.0)
        .map(|w| (w[1].wall, w[1].tick))
        .collect();
    eprintln!(
        "reverse play (seq {with_seq}, reorder {reorder}): p99 {:.2} mm, reverse p99 \
         {:.2} mm, max {:.2} mm, reverse rate {rate:.2} ticks/s, largest step {:.1} mm \
         ({:.1} mm at 5 m/s), behind the newest in reverse {:.0} ms (median), render \
         lag in reverse {:.0} ms (max), turns {turns:?}, {stats:?}",
        p99 * 1e3,
        reverse_p99 * 1e3,
        max * 1e3,
        step * 1e3,
        SPEED * FRAME * 1e3,
        behind_median * 1e3,
        lag * 1e3,
    );
    assert!(p99 < 0.01, "p99 error {p99} m");
    assert!(reverse_p99 < 0.01, "p99 error in reverse {reverse_p99} m");
    assert!(max < 0.0625, "max error {max} m");
    assert!(step < SPEED * FRAME * 1.5, "largest step {step} m");
    // Exactly two turns of the render tick, near where the server's
    // were (4 s and 10 s, plus transit and delay).
    assert_eq!(turns.len(), 2, "{turns:?}");
    assert!((4.0..4.4).contains(&turns[0].0) && (10.0..10.4).contains(&turns[1].0));
}

#[test]
fn reverse_play_renders_smooth_backward_motion() {
    forward_reverse_forward(true, false, 31);
}

#[test]
fn reverse_play_through_reordering_with_and_without_sequence_numbers() {
    forward_reverse_forward(true, true, 37);
    forward_reverse_forward(false, false, 41);
}

#[test]
fn pauses_around_reverse_play_freeze_and_resume_without_a_cut() {
    let mut sim = Sim::new(true, true, 47);
    sim.run(
        12.0,
        &[
            (3.0, Action::Pause),
            (5.0, Action::Play(-2.0)),
            (7.0, Action::Pause),
            (9.0, Action::Play(1.0)),
        ],
    );
    let stats = sim.buffer.stats();
    assert!(sim.events.is_empty(), "{:?}", sim.events);
    assert_eq!(stats.stalls, 0, "{stats:?}");
    // Frozen at the paused ticks (180 ticks forwards, then 240 back).
    for (from, to, tick) in [(3.4, 5.0, 1180.0), (7.4, 9.0, 940.0)] {
        for f in sim.between(from, to) {
            assert!(
                (f.tick - tick).abs() <= 1.0,
                "{} at {:.3} s",
                f.tick,
                f.wall
            );
        }
    }
    // Backwards at twice real time in between.
    let reverse = sim.between(5.6, 7.0);
    for w in reverse.windows(2) {
        assert!(w[1].tick < w[0].tick, "at {:.3} s", w[1].wall);
    }
    let rate = (reverse[reverse.len() - 1].tick - reverse[0].tick)
        / (reverse[reverse.len() - 1].wall - reverse[0].wall);
    assert!((rate + 2.0 * HZ).abs() < 4.0, "rate {rate} ticks/s");
    let settled = sim.between(1.0, 12.0);
    let p99 = percentile(settled.iter().map(error).collect(), 0.99);
    let step = largest_step(&settled);
    eprintln!(
        "pause, reverse ×2, pause, forwards: p99 {:.2} mm, reverse rate {rate:.1} ticks/s, \
         largest step {:.1} mm, {stats:?}",
        p99 * 1e3,
        step * 1e3
    );
    assert!(p99 < 0.01, "p99 error {p99} m");
    assert!(step < 2.0 * SPEED * FRAME * 1.5, "largest step {step} m");
}

#[test]
fn a_seek_during_reverse_play_is_one_discontinuity() {
    let mut sim = Sim::new(true, false, 43);
    sim.run(9.0, &[(3.0, Action::Play(-1.0)), (6.0, Action::Seek(5000))]);
    assert_eq!(sim.buffer.stats().discontinuities, 1, "{:?}", sim.events);
    assert_eq!(sim.events.len(), 1, "{:?}", sim.events);
    let after = sim.between(6.5, 9.0);
    assert!(after.iter().all(|f| f.tick <= 5000.0 && f.tick > 4800.0));
    for w in after.windows(2) {
        assert!(w[1].tick < w[0].tick);
    }
    assert!(after.iter().map(error).fold(0.0, f64::max) < 0.03);
}
