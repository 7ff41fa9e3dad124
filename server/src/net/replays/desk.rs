//! Which replays play, and what each sends in a snapshot slot: the
//! sans-IO core of players' replays, which the snapshot stage drives once
//! a slot after its live clients, and the tests drive the same way on
//! virtual time.
//!
//! Replays take a bounded share of the machine: at most
//! [`ReplayLimits::max_playing`] play at once; beyond, a request waits in
//! a queue of [`ReplayLimits::max_queued`] for at most
//! [`ReplayLimits::queue_deadline`], and is refused as `Busy` past it (or
//! at once when the queue is full). The stage gives the replays of a slot
//! only what is left of its time after the live clients
//! ([`ReplayDesk::serve`]'s `more`), so a replay waits a slot rather than
//! a live snapshot. Replays showing the same frame in a slot share its
//! entity deltas ([`DeltaPool`]), and every replay reads the one copy of
//! each frame the [`ReplayWindow`] holds.

use std::collections::{BTreeMap, HashMap, VecDeque};
use std::time::{Duration, Instant};

use inertia_protocol::replay::{
    ReplayAnswer, ReplayAsk, ReplayDatagram, ReplayEnd, ReplayRefusal, ReplayRequest,
};
use inertia_protocol::snapshot::{QuantizedFrame, SharedDeltas};
use inertia_protocol::{EntityId, ServerSession, SessionConfig};

use super::window::ReplayWindow;

/// How many replays play, how long one may wait, and the clocks they run
/// on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReplayLimits {
    /// Replays playing at once, at most (0: none ever plays).
    pub max_playing: usize,
    /// Requests waiting for room, at most.
    pub max_queued: usize,
    /// Longest a request waits for room before it is refused as busy.
    pub queue_deadline: Duration,
    /// Physics ticks per simulation second, Hz.
    pub tick_hz: u32,
    /// Snapshot slots per wall second, Hz.
    pub snapshot_hz: u32,
}

impl ReplayLimits {
    /// `max_playing` at once, a queue of twice as many waiting at most
    /// half a second, on the server's clocks.
    pub fn new(max_playing: usize, tick_hz: u32, snapshot_hz: u32) -> Self {
        Self {
            max_playing,
            max_queued: max_playing * 2,
            queue_deadline: Duration::from_millis(500),
            tick_hz: tick_hz.max(1),
            snapshot_hz: snapshot_hz.max(1),
        }
    }
}

/// What the desk has for a client: an answer for its control stream, or
/// a replay datagram.
#[derive(Debug, Clone, PartialEq)]
pub enum DeskOutput {
    /// Tell connection `connection` this about its replay.
    Answer {
        /// The client's connection.
        connection: u64,
        /// What to tell it.
        answer: ReplayAnswer,
    },
    /// Send connection `connection` this replay datagram.
    Datagram {
        /// The client's connection.
        connection: u64,
        /// The datagram ([`ReplayDatagram::snapshot`]).
        bytes: Vec<u8>,
    },
}

/// One replay playing.
#[derive(Debug)]
struct Playing {
    number: u16,
    request: ReplayRequest,
    /// Its own views, sequence numbers and acknowledgements, centred on
    /// the focus.
    session: ServerSession,
    /// Where it has got to, ticks (fractional: a slow replay moves less
    /// than a tick a slot).
    playhead: f64,
    /// The tick of the last frame it sent.
    shown: Option<u64>,
}

/// A request waiting for room.
#[derive(Debug)]
struct Waiting {
    connection: u64,
    request: ReplayRequest,
    focus: Option<EntityId>,
    since: Instant,
}

/// The replays playing and waiting (see the [module docs](self)).
#[derive(Debug)]
pub struct ReplayDesk {
    limits: ReplayLimits,
    session: SessionConfig,
    /// By connection: a client has one replay at most.
    playing: BTreeMap<u64, Playing>,
    waiting: VecDeque<Waiting>,
    /// Each connection's next replay number.
    numbers: BTreeMap<u64, u16>,
    /// Which replay starts a slot's round, so that replays left without
    /// time in one slot go first in the next.
    turn: usize,
    deltas: DeltaPool,
}

impl ReplayDesk {
    /// A desk that plays nothing yet, coding every replay as `session`
    /// codes a live client's snapshots.
    pub fn new(limits: ReplayLimits, session: SessionConfig) -> Self {
        Self {
            limits,
            session,
            playing: BTreeMap::new(),
            waiting: VecDeque::new(),
            numbers: BTreeMap::new(),
            turn: 0,
            deltas: DeltaPool::default(),
        }
    }

    /// Replays playing.
    pub fn playing(&self) -> usize {
        self.playing.len()
    }

    /// Requests waiting for room.
    pub fn waiting(&self) -> usize {
        self.waiting.len()
    }

    /// Connection `connection` asks `ask` at `now`; `avatar` is its
    /// avatar, which a replay without a focus centres on. Answers (a
    /// refusal, a replay ended by this one, a start) go to `out`.
    pub fn ask(
        &mut self,
        connection: u64,
        ask: ReplayAsk,
        avatar: Option<EntityId>,
        window: &ReplayWindow,
        now: Instant,
        out: &mut Vec<DeskOutput>,
    ) {
        self.waiting.retain(|w| w.connection != connection);
        let request = match ask {
            ReplayAsk::Cancel => {
                self.end(connection, ReplayEnd::Cancelled, out);
                return;
            }
            ReplayAsk::Play(request) => request,
        };
        if let Err(why) = self.admissible(&request, window) {
            out.push(refusal(connection, why));
            return;
        }
        let focus = request.focus.or(avatar);
        if self.playing.contains_key(&connection) {
            // Its own place: the new replay takes it.
            self.end(connection, ReplayEnd::Replaced, out);
        } else if self.playing.len() >= self.limits.max_playing {
            if self.waiting.len() >= self.limits.max_queued {
                out.push(refusal(connection, ReplayRefusal::Busy));
            } else {
                self.waiting.push_back(Waiting {
                    connection,
                    request,
                    focus,
                    since: now,
                });
            }
            return;
        }
        self.start(connection, request, focus, window, out);
    }

    /// What any server refuses of `request` with `window` as it is.
    fn admissible(
        &self,
        request: &ReplayRequest,
        window: &ReplayWindow,
    ) -> Result<(), ReplayRefusal> {
        request.check()?;
        if !window.enabled() || self.limits.max_playing == 0 {
            return Err(ReplayRefusal::Disabled);
        }
        if request.ticks() > window.max_ticks() {
            return Err(ReplayRefusal::TooLong {
                max_ticks: window.max_ticks(),
            });
        }
        let (Some(oldest), Some(newest)) = (window.oldest(), window.newest()) else {
            return Err(ReplayRefusal::Future { newest: 0 });
        };
        if request.to_tick > newest {
            return Err(ReplayRefusal::Future { newest });
        }
        if request.from_tick < oldest {
            return Err(ReplayRefusal::TooOld { oldest });
        }
        Ok(())
    }

    fn start(
        &mut self,
        connection: u64,
        request: ReplayRequest,
        focus: Option<EntityId>,
        window: &ReplayWindow,
        out: &mut Vec<DeskOutput>,
    ) {
        let Some(first) = window.at_or_after(request.from_tick).map(|f| f.tick) else {
            out.push(refusal(connection, ReplayRefusal::Future { newest: 0 }));
            return;
        };
        let number = self.numbers.entry(connection).or_insert(0);
        let this = *number;
        *number = number.wrapping_add(1);
        let Ok(mut session) = ServerSession::new(self.session.clone()) else {
            return;
        };
        if let Some(focus) = focus {
            session.set_avatar(focus);
        }
        out.push(DeskOutput::Answer {
            connection,
            answer: ReplayAnswer::Started {
                replay: this,
                from_tick: first,
                to_tick: request.to_tick,
                speed: request.speed,
            },
        });
        self.playing.insert(
            connection,
            Playing {
                number: this,
                request: ReplayRequest {
                    from_tick: first,
                    ..request
                },
                session,
                playhead: first as f64,
                shown: None,
            },
        );
    }

    /// Ends connection `connection`'s replay, if one plays, for `why`.
    fn end(&mut self, connection: u64, why: ReplayEnd, out: &mut Vec<DeskOutput>) {
        if let Some(p) = self.playing.remove(&connection) {
            out.push(DeskOutput::Answer {
                connection,
                answer: ReplayAnswer::Ended {
                    replay: p.number,
                    why,
                },
            });
        }
    }

    /// Connection `connection` acknowledged its replay `replay`'s snapshot
    /// `sequence`.
    pub fn on_ack(&mut self, connection: u64, replay: u16, sequence: u16) {
        if let Some(p) = self.playing.get_mut(&connection) {
            if p.number == replay {
                p.session.on_ack(sequence);
            }
        }
    }

    /// Forgets every connection for which `served` is false (it left):
    /// its replay stops without an answer, its request waits no more.
    pub fn retain(&mut self, served: impl Fn(u64) -> bool) {
        self.playing.retain(|c, _| served(*c));
        self.waiting.retain(|w| served(w.connection));
        self.numbers.retain(|c, _| served(*c));
    }

    /// One snapshot slot at `now`: starts waiting requests where there is
    /// room (refusing those past their deadline), then sends each replay
    /// playing its next frame from `window`, at most `max_datagram(c)`
    /// bytes for connection `c`, while `more()` says the slot has time
    /// left; a replay left without time waits for the next slot, where it
    /// goes first. Replays that have shown their last tick end.
    pub fn serve(
        &mut self,
        window: &ReplayWindow,
        now: Instant,
        max_datagram: impl Fn(u64) -> usize,
        mut more: impl FnMut() -> bool,
        out: &mut Vec<DeskOutput>,
    ) {
        self.admit_waiting(window, now, out);
        if self.playing.is_empty() {
            return;
        }
        let per_slot = f64::from(self.limits.tick_hz) / f64::from(self.limits.snapshot_hz);
        let order: Vec<u64> = self.playing.keys().copied().collect();
        let start = self.turn % order.len();
        let mut served = 0;
        for &connection in order[start..].iter().chain(&order[..start]) {
            if !more() {
                break;
            }
            served += 1;
            let Some(p) = self.playing.get_mut(&connection) else {
                continue;
            };
            match step(p, window, per_slot) {
                Step::Show(frame) => {
                    let deltas = self.deltas.for_frame(&frame);
                    let snapshot = p.session.snapshot_at(
                        &frame,
                        p.request.speed,
                        deltas,
                        max_datagram(connection).saturating_sub(3),
                    );
                    out.push(DeskOutput::Datagram {
                        connection,
                        bytes: ReplayDatagram::snapshot(p.number, &snapshot),
                    });
                    p.shown = Some(frame.tick);
                    if last_shown(p, window) {
                        self.end(connection, ReplayEnd::Finished, out);
                    }
                }
                Step::Wait => {}
                Step::Passed => self.end(connection, ReplayEnd::WindowPassed, out),
            }
        }
        // Those left without time go first next slot.
        self.turn = start + served;
        self.deltas.end_slot();
    }

    fn admit_waiting(&mut self, window: &ReplayWindow, now: Instant, out: &mut Vec<DeskOutput>) {
        while let Some(w) = self.waiting.front() {
            if now.saturating_duration_since(w.since) > self.limits.queue_deadline {
                let w = self.waiting.pop_front().expect("looked at");
                out.push(refusal(w.connection, ReplayRefusal::Busy));
                continue;
            }
            if self.playing.len() >= self.limits.max_playing {
                break;
            }
            let w = self.waiting.pop_front().expect("looked at");
            match self.admissible(&w.request, window) {
                Ok(()) => self.start(w.connection, w.request, w.focus, window, out),
                Err(why) => out.push(refusal(w.connection, why)),
            }
        }
    }
}

/// What a replay does in a slot.
enum Step {
    /// Send this frame.
    Show(std::sync::Arc<QuantizedFrame>),
    /// No new frame yet (a slow replay between two frames).
    Wait,
    /// The frames it is still to show left the window.
    Passed,
}

/// Moves `p`'s playhead one slot on and says what it shows.
fn step(p: &mut Playing, window: &ReplayWindow, per_slot: f64) -> Step {
    let Some(shown) = p.shown else {
        // The first slot shows the first frame.
        return match window.at_or_after(p.request.from_tick) {
            Some(f) if f.tick <= p.request.to_tick => Step::Show(f.clone()),
            _ => Step::Passed,
        };
    };
    p.playhead += per_slot * f64::from(p.request.speed);
    let until = (p.playhead.floor() as u64).min(p.request.to_tick);
    match window.at_or_before(until) {
        Some(f) if f.tick > shown => Step::Show(f.clone()),
        // The playhead fell behind the window's oldest frame (a replay
        // slower than real time near the window's end).
        None => Step::Passed,
        Some(_) => Step::Wait,
    }
}

/// Whether `p` has shown the last frame of its stretch.
fn last_shown(p: &Playing, window: &ReplayWindow) -> bool {
    p.shown.is_some_and(|shown| {
        shown >= p.request.to_tick
            || window
                .after(shown)
                .is_none_or(|next| next.tick > p.request.to_tick)
    })
}

fn refusal(connection: u64, why: ReplayRefusal) -> DeskOutput {
    DeskOutput::Answer {
        connection,
        answer: ReplayAnswer::Refused(why),
    }
}

/// The entity deltas of the frames replays show in one slot, one
/// [`SharedDeltas`] per frame: replays showing the same frame code each
/// entity's delta against a given baseline once between them.
#[derive(Debug, Default)]
struct DeltaPool {
    by_frame: HashMap<u64, SharedDeltas>,
    used: Vec<u64>,
}

impl DeltaPool {
    fn for_frame(&mut self, frame: &QuantizedFrame) -> &mut SharedDeltas {
        self.used.push(frame.serial());
        self.by_frame.entry(frame.serial()).or_default()
    }

    /// Keeps the deltas of the frames shown this slot only (a slow replay
    /// may show none; the next slot's frames are others).
    fn end_slot(&mut self) {
        let used = std::mem::take(&mut self.used);
        self.by_frame.retain(|serial, _| used.contains(serial));
    }
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use glam::{DQuat, DVec3};
    use inertia_protocol::snapshot::{SnapshotConfig, SnapshotDecoder, ViewEntity};
    use inertia_protocol::EntityState;

    use super::*;

    const TICK_HZ: u32 = 60;
    const SNAPSHOT_HZ: u32 = 30;

    /// Three bodies moving at tick `tick`, quantized.
    fn frame(tick: u64) -> QuantizedFrame {
        let states: Vec<EntityState> = (1..=3u32)
            .map(|id| EntityState {
                id,
                position: DVec3::new(f64::from(id) + tick as f64 * 0.01 * f64::from(id), 1.0, 0.0),
                rotation: DQuat::from_rotation_y(tick as f64 * 0.02),
                linear_velocity: DVec3::new(0.6 * f64::from(id), 0.0, 0.0),
                angular_velocity: DVec3::ZERO,
                asleep: false,
            })
            .collect();
        QuantizedFrame::new(tick, 1.0, false, &states, &SnapshotConfig::default())
    }

    fn config() -> SessionConfig {
        SessionConfig::new(SnapshotConfig::default(), 1200)
    }

    fn desk(max_playing: usize, max_queued: usize) -> ReplayDesk {
        ReplayDesk::new(
            ReplayLimits {
                max_queued,
                ..ReplayLimits::new(max_playing, TICK_HZ, SNAPSHOT_HZ)
            },
            config(),
        )
    }

    fn play(from_tick: u64, to_tick: u64, speed: f32) -> ReplayAsk {
        ReplayAsk::Play(ReplayRequest {
            from_tick,
            to_tick,
            speed,
            focus: None,
        })
    }

    fn answers(out: &[DeskOutput]) -> Vec<(u64, ReplayAnswer)> {
        out.iter()
            .filter_map(|o| match o {
                DeskOutput::Answer { connection, answer } => Some((*connection, *answer)),
                DeskOutput::Datagram { .. } => None,
            })
            .collect()
    }

    /// A window of ticks 0, 2, … `last`, and the views a live client
    /// decoded of the same frames, by tick.
    fn live_until(last: u64) -> (ReplayWindow, BTreeMap<u64, Vec<ViewEntity>>) {
        let mut window = ReplayWindow::new(30 * u64::from(TICK_HZ), usize::MAX);
        let mut session = ServerSession::new(config()).unwrap();
        let mut decoder = SnapshotDecoder::new(SnapshotConfig::default()).unwrap();
        let mut shared = SharedDeltas::new();
        let mut views = BTreeMap::new();
        for tick in (0..=last).step_by(2) {
            let f = frame(tick);
            let bytes = session
                .poll_snapshot(&f, &mut shared, tick / 2, 1200)
                .unwrap();
            let snap = decoder.decode(&bytes).unwrap();
            let sequence = snap.sequence;
            session.on_ack(sequence);
            views.insert(tick, decoder.entities(sequence).unwrap());
            window.push(&f);
        }
        (window, views)
    }

    #[test]
    fn a_replay_shows_exactly_what_the_live_clients_were_sent_at_its_speed_and_ends() {
        let (window, live) = live_until(400);
        let mut desk = desk(4, 4);
        let now = Instant::now();
        let mut out = Vec::new();
        desk.ask(7, play(100, 200, 1.0), None, &window, now, &mut out);
        assert_eq!(
            answers(&out),
            [(
                7,
                ReplayAnswer::Started {
                    replay: 0,
                    from_tick: 100,
                    to_tick: 200,
                    speed: 1.0
                }
            )]
        );
        let mut decoder = SnapshotDecoder::new(SnapshotConfig::default()).unwrap();
        let mut shown = Vec::new();
        for slot in 0..200 {
            out.clear();
            desk.serve(&window, now, |_| 1200, || true, &mut out);
            for o in &out {
                match o {
                    DeskOutput::Datagram { connection, bytes } => {
                        assert_eq!(*connection, 7);
                        let Ok(ReplayDatagram::Snapshot { replay, snapshot }) =
                            ReplayDatagram::decode_snapshot(bytes)
                        else {
                            panic!("a replay datagram");
                        };
                        assert_eq!(replay, 0);
                        let snap = decoder.decode(snapshot).unwrap();
                        assert_eq!(snap.time_scale, 1.0);
                        let (tick, sequence) = (snap.tick, snap.sequence);
                        // Acknowledged every other slot, as a lossy link would.
                        if slot % 2 == 0 {
                            desk.on_ack(7, 0, sequence);
                        }
                        assert_eq!(
                            decoder.entities(sequence).unwrap(),
                            live[&tick],
                            "tick {tick}: the replay shows what was live"
                        );
                        shown.push(tick);
                    }
                    DeskOutput::Answer { answer, .. } => assert_eq!(
                        *answer,
                        ReplayAnswer::Ended {
                            replay: 0,
                            why: ReplayEnd::Finished
                        }
                    ),
                }
            }
            if desk.playing() == 0 {
                break;
            }
        }
        // At real time: a frame (2 ticks) a slot, every frame once.
        assert_eq!(shown, (100..=200).step_by(2).collect::<Vec<_>>());
        assert_eq!(desk.playing(), 0);

        // At a quarter speed, each frame shows once, one slot in four.
        let mut slow = Vec::new();
        out.clear();
        desk.ask(7, play(100, 110, 0.25), None, &window, now, &mut out);
        for _ in 0..40 {
            out.clear();
            desk.serve(&window, now, |_| 1200, || true, &mut out);
            slow.push(out.iter().any(|o| matches!(o, DeskOutput::Datagram { .. })));
        }
        assert_eq!(slow.iter().filter(|s| **s).count(), 6);
        assert_eq!(&slow[..5], [true, false, false, false, true]);
    }

    #[test]
    fn stretches_the_window_does_not_hold_are_refused_with_what_it_holds() {
        let (window, _) = live_until(400);
        let mut desk = desk(4, 4);
        let now = Instant::now();
        let refused = |desk: &mut ReplayDesk, ask| {
            let mut out = Vec::new();
            desk.ask(1, ask, None, &window, now, &mut out);
            match answers(&out)[..] {
                [(1, ReplayAnswer::Refused(why))] => why,
                ref other => panic!("{other:?}"),
            }
        };
        assert_eq!(
            refused(&mut desk, play(390, 500, 1.0)),
            ReplayRefusal::Future { newest: 400 }
        );
        assert_eq!(
            refused(&mut desk, play(0, 30 * 60 + 1, 1.0)),
            ReplayRefusal::TooLong { max_ticks: 1800 }
        );
        assert_eq!(refused(&mut desk, play(10, 10, 1.0)), ReplayRefusal::Empty);
        assert_eq!(refused(&mut desk, play(10, 20, 20.0)), ReplayRefusal::Speed);
        let mut short = ReplayWindow::new(100, usize::MAX);
        for t in (0..=400).step_by(2) {
            short.push(&frame(t));
        }
        let mut out = Vec::new();
        desk.ask(1, play(200, 300, 1.0), None, &short, now, &mut out);
        assert_eq!(
            answers(&out),
            [(
                1,
                ReplayAnswer::Refused(ReplayRefusal::TooOld { oldest: 300 })
            )]
        );
        let off = ReplayWindow::new(0, 0);
        out.clear();
        desk.ask(1, play(200, 300, 1.0), None, &off, now, &mut out);
        assert_eq!(
            answers(&out),
            [(1, ReplayAnswer::Refused(ReplayRefusal::Disabled))]
        );
        assert_eq!(desk.playing(), 0);
    }

    #[test]
    fn replays_beyond_the_limit_wait_until_their_deadline_and_are_then_refused_as_busy() {
        let (window, _) = live_until(400);
        let mut desk = desk(1, 1);
        let t0 = Instant::now();
        let mut out = Vec::new();
        desk.ask(1, play(100, 300, 1.0), None, &window, t0, &mut out);
        desk.ask(2, play(100, 300, 1.0), None, &window, t0, &mut out);
        desk.ask(3, play(100, 300, 1.0), None, &window, t0, &mut out);
        let a = answers(&out);
        assert!(matches!(a[0], (1, ReplayAnswer::Started { .. })));
        assert_eq!(a[1], (3, ReplayAnswer::Refused(ReplayRefusal::Busy)));
        assert_eq!((desk.playing(), desk.waiting()), (1, 1));
        // Room comes before the deadline: the one waiting starts.
        out.clear();
        desk.ask(1, ReplayAsk::Cancel, None, &window, t0, &mut out);
        desk.serve(
            &window,
            t0 + Duration::from_millis(100),
            |_| 1200,
            || true,
            &mut out,
        );
        let a = answers(&out);
        assert_eq!(
            a[0],
            (
                1,
                ReplayAnswer::Ended {
                    replay: 0,
                    why: ReplayEnd::Cancelled
                }
            )
        );
        assert!(matches!(a[1], (2, ReplayAnswer::Started { replay: 0, .. })));
        // Another waits, and its deadline passes first.
        out.clear();
        desk.ask(4, play(100, 300, 1.0), None, &window, t0, &mut out);
        desk.serve(
            &window,
            t0 + Duration::from_secs(1),
            |_| 1200,
            || true,
            &mut out,
        );
        assert_eq!(
            answers(&out),
            [(4, ReplayAnswer::Refused(ReplayRefusal::Busy))]
        );
        // A new request of the one playing replaces its replay in place.
        out.clear();
        desk.ask(2, play(150, 300, 2.0), None, &window, t0, &mut out);
        assert_eq!(
            answers(&out),
            [
                (
                    2,
                    ReplayAnswer::Ended {
                        replay: 0,
                        why: ReplayEnd::Replaced
                    }
                ),
                (
                    2,
                    ReplayAnswer::Started {
                        replay: 1,
                        from_tick: 150,
                        to_tick: 300,
                        speed: 2.0
                    }
                )
            ]
        );
        // A client that left is forgotten without an answer.
        desk.retain(|c| c != 2);
        assert_eq!(desk.playing(), 0);
    }

    #[test]
    fn a_slot_without_time_left_holds_the_replays_back_and_a_slow_one_the_window_passes_ends() {
        let (window, _) = live_until(400);
        let mut desk = desk(4, 4);
        let now = Instant::now();
        let mut out = Vec::new();
        desk.ask(1, play(300, 380, 1.0), None, &window, now, &mut out);
        desk.ask(2, play(300, 380, 1.0), None, &window, now, &mut out);
        out.clear();
        desk.serve(&window, now, |_| 1200, || false, &mut out);
        assert!(out.is_empty(), "no time: nothing sent, nothing lost");
        let mut budget = 1;
        desk.serve(
            &window,
            now,
            |_| 1200,
            || {
                budget -= 1;
                budget >= 0
            },
            &mut out,
        );
        assert_eq!(out.len(), 1, "one replay had time");
        out.clear();
        desk.serve(&window, now, |_| 1200, || true, &mut out);
        assert_eq!(out.len(), 2);

        // A window of 40 ticks that moves on at real time passes a replay
        // at a tenth of it.
        let mut short = ReplayWindow::new(40, usize::MAX);
        for t in (0..=400).step_by(2) {
            short.push(&frame(t));
        }
        let mut desk = self::desk(4, 4);
        out.clear();
        desk.ask(1, play(362, 400, 0.1), None, &short, now, &mut out);
        let mut tick = 400;
        for _ in 0..100 {
            tick += 2;
            short.push(&frame(tick));
            desk.serve(&short, now, |_| 1200, || true, &mut out);
        }
        assert!(
            answers(&out).contains(&(
                1,
                ReplayAnswer::Ended {
                    replay: 0,
                    why: ReplayEnd::WindowPassed
                }
            )),
            "{:?}",
            answers(&out)
        );
        assert_eq!(desk.playing(), 0);
    }
}
