//! USARSim's text protocol (NIST's UDK sources, `USARBotAPI`): parsing a command line into its
//! type and `{Key value}` arguments, and the number formats and frame of its messages.
//!
//! A line is `TYPE {Key value} {Key value} …`: the value is everything after the key up to the
//! closing brace, trimmed (it may hold spaces, as `{StartPoses …}` does); vectors are
//! comma-separated. Keys are matched as written, types without regard to case, as USARSim does.
//! USARSim's frame is x forward, y right, z down, yaw clockwise: y, z and yaw change sign
//! against radarnav's (REP-103).

use std::fmt::Write;

use thiserror::Error;

use crate::pose::Pose;

/// The longest line taken, bytes: longer ones are refused (a client cannot make the server hold
/// unbounded text).
pub const MAX_LINE: usize = 64 * 1024;

/// Most `{Key value}` arguments in a line.
pub const MAX_ARGS: usize = 64;

/// A line that is not a command.
#[derive(Clone, Debug, Error, PartialEq, Eq)]
pub enum ParseError {
    /// Nothing but blanks.
    #[error("empty line")]
    Empty,
    /// Longer than [`MAX_LINE`].
    #[error("line longer than {MAX_LINE} bytes")]
    TooLong,
    /// A `{` without its `}`, a `}` without its `{`, or text between arguments.
    #[error("malformed argument at byte {0}: expected a key and a value in braces")]
    Malformed(usize),
    /// More than [`MAX_ARGS`] arguments.
    #[error("more than {MAX_ARGS} arguments")]
    TooManyArgs,
}

/// A parsed line: its type (as written) and its arguments in order.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Message {
    /// The first word, e.g. `INIT`.
    pub kind: String,
    /// `(key, value)` pairs.
    pub args: Vec<(String, String)>,
}

impl Message {
    /// Parses one line (without its line end).
    pub fn parse(line: &str) -> Result<Self, ParseError> {
        if line.len() > MAX_LINE {
            return Err(ParseError::TooLong);
        }
        let line = line.trim();
        if line.is_empty() {
            return Err(ParseError::Empty);
        }
        // The type ends at the first blank or brace.
        let end = line
            .find(|c: char| c.is_whitespace() || c == '{')
            .unwrap_or(line.len());
        let kind = line[..end].to_owned();
        if kind.is_empty() || kind.contains('}') {
            return Err(ParseError::Malformed(0));
        }
        let mut args = Vec::new();
        let mut rest = &line[end..];
        loop {
            let trimmed = rest.trim_start();
            let at = line.len() - trimmed.len();
            if trimmed.is_empty() {
                break;
            }
            let Some(body) = trimmed.strip_prefix('{') else {
                return Err(ParseError::Malformed(at));
            };
            let Some(close) = body.find('}') else {
                return Err(ParseError::Malformed(at));
            };
            let inner = body[..close].trim();
            if inner.contains('{') {
                return Err(ParseError::Malformed(at));
            }
            let (key, value) = match inner.find(char::is_whitespace) {
                Some(i) => (&inner[..i], inner[i..].trim()),
                None => (inner, ""),
            };
            if key.is_empty() {
                return Err(ParseError::Malformed(at));
            }
            if args.len() == MAX_ARGS {
                return Err(ParseError::TooManyArgs);
            }
            args.push((key.to_owned(), value.to_owned()));
            rest = &body[close + 1..];
        }
        Ok(Self { kind, args })
    }

    /// The value of the first argument `key` (matched as written, as USARSim does).
    pub fn get(&self, key: &str) -> Option<&str> {
        self.args
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }

    /// Whether the type is `kind`, whatever its case.
    pub fn is(&self, kind: &str) -> bool {
        self.kind.eq_ignore_ascii_case(kind)
    }
}

/// A comma-separated vector of three finite numbers (`"1.5,-2,0"`).
pub fn parse_vector(text: &str) -> Option<[f64; 3]> {
    let mut out = [0.0; 3];
    let mut parts = text.split(',');
    for v in &mut out {
        *v = parts.next()?.trim().parse::<f64>().ok()?;
        if !v.is_finite() {
            return None;
        }
    }
    parts.next().is_none().then_some(out)
}

/// A number as USARSim's `UnitsConverter.FloatString` writes it: the integer part, a point,
/// then `precision` digits of the fraction, truncated (not rounded); negative values get a
/// minus sign, -0 does not.
pub fn float_string(value: f64, precision: u32) -> String {
    let mut s = String::new();
    push_float(&mut s, value, precision);
    s
}

fn push_float(s: &mut String, value: f64, precision: u32) {
    let value = if value.is_finite() { value } else { 0.0 };
    let scale = 10u64.pow(precision.clamp(1, 9));
    if value < 0.0 {
        s.push('-');
    }
    let a = value.abs();
    let int = a.trunc();
    // The digits of the fraction, truncated; the epsilon keeps 0.3 from printing as 0.29.
    let frac = (((a - int) * scale as f64) * (1.0 + 1e-12)).floor() as u64;
    let frac = frac.min(scale - 1);
    let _ = write!(s, "{int:.0}.{frac:0width$}", width = precision as usize);
}

/// Three numbers as [`float_string`], comma-separated.
pub fn vector_string(v: [f64; 3], precision: u32) -> String {
    let mut s = String::new();
    for (i, x) in v.into_iter().enumerate() {
        if i > 0 {
            s.push(',');
        }
        push_float(&mut s, x, precision);
    }
    s
}

/// A yaw as USARSim reports it: clockwise, in [0, 2π).
pub fn usar_yaw(yaw: f64) -> f64 {
    (-yaw).rem_euclid(std::f64::consts::TAU)
}

/// A position in USARSim's frame: y and z change sign.
pub fn usar_position(p: &Pose) -> [f64; 3] {
    [p.x, -p.y, -p.z]
}

/// A pose given in USARSim's frame (location x, y, z; rotation roll, pitch, yaw) in
/// radarnav's: on the ground, y and yaw change sign.
pub fn from_usar(location: [f64; 3], rotation: [f64; 3]) -> Pose {
    Pose::new(
        location[0],
        -location[1],
        0.0,
        crate::pose::wrap_angle(-rotation[2]),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_command_parses_into_its_type_and_arguments() {
        let m = Message::parse(
            "INIT {ClassName USARBot.P3AT} {Name R1} {Location 4.5,-2.0,0.1}  {Rotation 0,0,1.57}",
        )
        .expect("parses");
        assert!(m.is("init"));
        assert_eq!(m.get("ClassName"), Some("USARBot.P3AT"));
        assert_eq!(m.get("Location"), Some("4.5,-2.0,0.1"));
        assert_eq!(m.get("location"), None);
        assert_eq!(
            parse_vector(m.get("Rotation").unwrap()),
            Some([0.0, 0.0, 1.57])
        );
        // Blanks inside braces and none between arguments, as USARSim's parser takes them.
        let m = Message::parse("Com2{  WithWhitespaces      88     }{More  whitespaces }")
            .expect("parses");
        assert_eq!(m.kind, "Com2");
        assert_eq!(m.get("WithWhitespaces"), Some("88"));
        assert_eq!(m.get("More"), Some("whitespaces"));
        assert_eq!(Message::parse("GETSTARTPOSES").unwrap().args, vec![]);
    }

    #[test]
    fn malformed_lines_are_errors() {
        assert_eq!(Message::parse("   "), Err(ParseError::Empty));
        for bad in [
            "DRIVE {Left 1",
            "DRIVE Left 1}",
            "DRIVE {Left {1}}",
            "DRIVE {} ",
            "DRIVE {Left 1} x",
            "}",
        ] {
            assert!(
                matches!(Message::parse(bad), Err(ParseError::Malformed(_))),
                "{bad}"
            );
        }
        assert_eq!(
            Message::parse(&"x".repeat(MAX_LINE + 1)),
            Err(ParseError::TooLong)
        );
        let many = format!("SET {}", "{A 1} ".repeat(MAX_ARGS + 1));
        assert_eq!(Message::parse(&many), Err(ParseError::TooManyArgs));
        for bad in ["1,2", "1,2,3,4", "a,b,c", "1,nan,2", "1,inf,2"] {
            assert_eq!(parse_vector(bad), None, "{bad}");
        }
    }

    #[test]
    fn numbers_are_truncated_as_usarsims_float_string() {
        assert_eq!(float_string(5.43219, 2), "5.43");
        assert_eq!(float_string(2.999, 2), "2.99");
        assert_eq!(float_string(-1.005, 2), "-1.00");
        assert_eq!(float_string(0.3, 2), "0.30");
        assert_eq!(float_string(-0.0, 2), "0.00");
        assert_eq!(float_string(0.017453, 4), "0.0174");
        assert_eq!(float_string(std::f64::consts::PI, 4), "3.1415");
        assert_eq!(float_string(80.0, 2), "80.00");
        assert_eq!(vector_string([1.0, -2.5, 0.0], 3), "1.000,-2.500,0.000");
    }

    #[test]
    fn usarsims_frame_mirrors_y_and_yaw() {
        let p = Pose::new(1.0, 2.0, 0.3, 0.5);
        assert_eq!(usar_position(&p), [1.0, -2.0, -0.3]);
        assert!((usar_yaw(0.5) - (std::f64::consts::TAU - 0.5)).abs() < 1e-12);
        let back = from_usar([1.0, -2.0, 0.0], [0.0, 0.0, usar_yaw(0.5)]);
        assert!((back.y - 2.0).abs() < 1e-12 && (back.yaw - 0.5).abs() < 1e-12);
    }
}
