//! The USARSim server's sockets: a thread per client (at most [`MAX_CLIENTS`]), each running
//! its own robot's simulation in step with the server's clock: simulated time advances at
//! `speed` × the wall clock, shared by every client, so message times agree across clients.
//! Robots of different clients do not see each other (each drives in the scenario's world).

use std::io::{self, BufWriter, ErrorKind, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use thiserror::Error;

use super::protocol::{MAX_LINE, Message, ParseError};
use super::session::{self, Driving, Init};
use crate::setup::{Robot, Scenario};

/// Clients served at once (USARSim's `MaxConnections`).
pub const MAX_CLIENTS: usize = 64;

/// How long a write to a client may block before the client counts as gone.
const WRITE_TIMEOUT: Duration = Duration::from_secs(10);

/// A server that could not run.
#[derive(Debug, Error)]
pub enum ServeError {
    /// The listening socket failed.
    #[error("listening socket: {0}")]
    Io(#[from] io::Error),
}

/// How the server runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ServeOptions {
    /// Simulated seconds per wall-clock second (1: real time).
    pub speed: f64,
    /// Seed of every client's robot (odometry noise, sensor noise).
    pub seed: u64,
}

/// What the server tells its operator (connections, ends, lag): a line each.
pub type Log<'a> = &'a (dyn Fn(String) + Sync);

/// The world the clients share and how it runs.
struct Shared<'a> {
    scenario: &'a Scenario,
    template: &'a Robot,
    options: ServeOptions,
    epoch: Instant,
    stop: &'a AtomicBool,
    log: Log<'a>,
}

impl Shared<'_> {
    /// Server (simulated) time now, s.
    fn now(&self) -> f64 {
        self.epoch.elapsed().as_secs_f64() * self.options.speed
    }

    /// The wall-clock instant of server time `t`.
    fn instant(&self, t: f64) -> Instant {
        self.epoch + Duration::from_secs_f64((t / self.options.speed).max(0.0))
    }
}

/// Serves `scenario` on `listener` until `stop` is set: every client may `INIT` a robot like
/// `template` (its vehicle and sensors) at a pose of its choice.
pub fn serve(
    listener: &TcpListener,
    scenario: &Scenario,
    template: &Robot,
    options: ServeOptions,
    stop: &AtomicBool,
    log: Log<'_>,
) -> Result<(), ServeError> {
    listener.set_nonblocking(true)?;
    let shared = Shared {
        scenario,
        template,
        options,
        epoch: Instant::now(),
        stop,
        log,
    };
    let active = AtomicUsize::new(0);
    let mut number = 0usize;
    std::thread::scope(|scope| {
        while !stop.load(Ordering::Relaxed) {
            match listener.accept() {
                Ok((stream, addr)) => {
                    number += 1;
                    if active.load(Ordering::Relaxed) >= MAX_CLIENTS {
                        let mut s = stream;
                        let _ = s.write_all(
                            format!(
                                "{}\r\n",
                                session::error(&format!("server full: {MAX_CLIENTS} clients"))
                            )
                            .as_bytes(),
                        );
                        continue;
                    }
                    active.fetch_add(1, Ordering::Relaxed);
                    let (shared, active) = (&shared, &active);
                    scope.spawn(move || {
                        (shared.log)(format!("client {number} connected from {addr}"));
                        let name = format!("robot{number}");
                        match client(stream, shared, &name) {
                            Ok(end) => (shared.log)(format!("client {number}: {end}")),
                            Err(e) => (shared.log)(format!("client {number}: {e}")),
                        }
                        active.fetch_sub(1, Ordering::Relaxed);
                    });
                }
                Err(e) if e.kind() == ErrorKind::WouldBlock => {
                    std::thread::sleep(Duration::from_millis(20));
                }
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                // A connection that failed before it was accepted ends only itself.
                Err(e) if is_connection_error(&e) => {}
                Err(e) => return Err(ServeError::Io(e)),
            }
        }
        Ok(())
    })
}

fn is_connection_error(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        ErrorKind::ConnectionAborted | ErrorKind::ConnectionReset | ErrorKind::TimedOut
    )
}

/// A line read from a client, or why there is none.
enum Got {
    Line(String),
    TooLong,
    Timeout,
    Closed,
}

/// Splits a client's bytes into lines ending in CR, LF or both, with at most [`MAX_LINE`]
/// bytes held.
struct Lines {
    stream: TcpStream,
    buf: Vec<u8>,
    /// Skipping the rest of a line that was too long.
    skipping: bool,
}

impl Lines {
    fn next(&mut self, timeout: Duration) -> io::Result<Got> {
        loop {
            if let Some(i) = self.buf.iter().position(|&b| b == b'\r' || b == b'\n') {
                let line: Vec<u8> = self.buf.drain(..=i).collect();
                if std::mem::take(&mut self.skipping) {
                    continue;
                }
                let text = String::from_utf8_lossy(&line[..i]).into_owned();
                if text.trim().is_empty() {
                    continue;
                }
                return Ok(Got::Line(text));
            }
            if self.buf.len() > MAX_LINE {
                self.buf.clear();
                let first = !self.skipping;
                self.skipping = true;
                if first {
                    return Ok(Got::TooLong);
                }
            }
            self.stream
                .set_read_timeout(Some(timeout.max(Duration::from_millis(1))))?;
            let mut chunk = [0u8; 4096];
            match self.stream.read(&mut chunk) {
                Ok(0) => return Ok(Got::Closed),
                Ok(n) => self.buf.extend_from_slice(&chunk[..n]),
                Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {
                    return Ok(Got::Timeout);
                }
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(e) if is_connection_error(&e) => return Ok(Got::Closed),
                Err(e) => return Err(e),
            }
        }
    }
}

/// A client's outgoing lines, CR LF each.
struct Out(BufWriter<TcpStream>);

impl Out {
    fn send(&mut self, line: &str) -> io::Result<()> {
        self.0.write_all(line.as_bytes())?;
        self.0.write_all(b"\r\n")
    }
}

/// A line that is not a command, as its error reply; `None` for a blank one.
fn parse(line: &str) -> Result<Message, Option<String>> {
    Message::parse(line).map_err(|e| match e {
        ParseError::Empty => None,
        e => Some(session::error(&e.to_string())),
    })
}

/// Serves one client until it leaves or the server stops; returns how it ended.
fn client(stream: TcpStream, shared: &Shared<'_>, fallback_name: &str) -> io::Result<String> {
    stream.set_nodelay(true)?;
    // A client that stops reading ends its own session, not the server's shutdown.
    stream.set_write_timeout(Some(WRITE_TIMEOUT))?;
    let mut lines = Lines {
        stream: stream.try_clone()?,
        buf: Vec::new(),
        skipping: false,
    };
    let mut out = Out(BufWriter::new(stream));
    out.send(&session::greeting(shared.scenario))?;
    out.0.flush()?;
    loop {
        let Some(init) = wait_for_init(&mut lines, &mut out, shared, fallback_name)? else {
            return Ok("left before INIT".into());
        };
        let robot = Robot {
            name: init.name,
            start: init.start,
            ..shared.template.clone()
        };
        let driving = Driving::new(
            &shared.scenario.world,
            &robot,
            shared.scenario.sim.dt,
            shared.options.seed,
            shared.now(),
        );
        match driving {
            Ok(d) => {
                let end = drive(d, &mut lines, &mut out, shared)?;
                return Ok(format!("{} {end}", robot.name));
            }
            Err(reply) => {
                out.send(&reply)?;
                out.0.flush()?;
            }
        }
    }
}

/// Answers `GETSTARTPOSES` and errors until a valid `INIT`; `None` if the client left first.
fn wait_for_init(
    lines: &mut Lines,
    out: &mut Out,
    shared: &Shared<'_>,
    fallback_name: &str,
) -> io::Result<Option<Init>> {
    while !shared.stop.load(Ordering::Relaxed) {
        let reply = match lines.next(Duration::from_millis(100))? {
            Got::Closed => return Ok(None),
            Got::Timeout => continue,
            Got::TooLong => Some(session::error(&ParseError::TooLong.to_string())),
            Got::Line(line) => match parse(&line) {
                Err(reply) => reply,
                Ok(m) if m.is("GETSTARTPOSES") => Some(session::start_poses(shared.scenario)),
                Ok(m) if m.is("INIT") => {
                    match session::parse_init(&m, shared.scenario, fallback_name) {
                        Ok(init) => return Ok(Some(init)),
                        Err(reply) => Some(reply),
                    }
                }
                Ok(m) => Some(session::error(&format!(
                    "{}: no robot on this connection yet; INIT one first",
                    m.kind
                ))),
            },
        };
        if let Some(reply) = reply {
            out.send(&reply)?;
            out.0.flush()?;
        }
    }
    Ok(None)
}

/// Runs the client's robot in step with the server clock, taking its commands between steps.
fn drive(
    mut d: Driving<'_>,
    lines: &mut Lines,
    out: &mut Out,
    shared: &Shared<'_>,
) -> io::Result<String> {
    let start = d.start_time();
    let mut worst_lag = Duration::ZERO;
    loop {
        if shared.stop.load(Ordering::Relaxed) {
            return Ok(format!(
                "server stopped; worst lag behind the clock {worst_lag:?}"
            ));
        }
        if d.done() {
            return Ok("simulation reached its longest time".into());
        }
        let due = shared.instant(start + d.time());
        let now = Instant::now();
        if now < due {
            let reply = match lines.next(due - now)? {
                Got::Closed => {
                    return Ok(format!(
                        "left after {:.1} s; worst lag behind the clock {worst_lag:?}",
                        d.time()
                    ));
                }
                Got::Timeout => continue,
                Got::TooLong => vec![session::error(&ParseError::TooLong.to_string())],
                Got::Line(line) => match parse(&line) {
                    Err(reply) => reply.into_iter().collect(),
                    Ok(m) if m.is("GETSTARTPOSES") => vec![session::start_poses(shared.scenario)],
                    Ok(m) => d.handle(&m),
                },
            };
            for r in &reply {
                out.send(r)?;
            }
            out.0.flush()?;
            continue;
        }
        worst_lag = worst_lag.max(now - due);
        for line in d.step() {
            out.send(&line)?;
        }
        out.0.flush()?;
    }
}
