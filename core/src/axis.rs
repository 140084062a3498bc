//! Cartesian axes of the machine (force inputs, TCP responses and axis positions).

use serde::{Deserialize, Serialize};

/// One machine axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Axis {
    /// X axis.
    X,
    /// Y axis.
    Y,
    /// Z axis.
    Z,
}

impl Axis {
    /// All three axes in order.
    pub const ALL: [Axis; 3] = [Axis::X, Axis::Y, Axis::Z];

    /// Index 0, 1, 2.
    pub fn index(self) -> usize {
        self as usize
    }

    /// Lower-case letter, as used in column and channel names.
    pub fn letter(self) -> char {
        match self {
            Axis::X => 'x',
            Axis::Y => 'y',
            Axis::Z => 'z',
        }
    }

    /// Parses `x`, `y` or `z` (either case).
    pub fn from_letter(c: char) -> Option<Axis> {
        match c.to_ascii_lowercase() {
            'x' => Some(Axis::X),
            'y' => Some(Axis::Y),
            'z' => Some(Axis::Z),
            _ => None,
        }
    }
}

impl std::fmt::Display for Axis {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.letter())
    }
}

/// A response/force channel: response along `output` per unit force along `input`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub struct Channel {
    /// Response axis.
    pub output: Axis,
    /// Force axis.
    pub input: Axis,
}

impl Channel {
    /// New channel `output` per `input`.
    pub fn new(output: Axis, input: Axis) -> Self {
        Channel { output, input }
    }

    /// Name as in the FRF CSV (`yx` = response y per force x).
    pub fn name(&self) -> String {
        format!("{}{}", self.output.letter(), self.input.letter())
    }

    /// Parses a two-letter channel name such as `xx` or `yx`.
    pub fn parse(s: &str) -> Option<Channel> {
        let mut it = s.chars();
        let o = Axis::from_letter(it.next()?)?;
        let i = Axis::from_letter(it.next()?)?;
        if it.next().is_some() {
            return None;
        }
        Some(Channel::new(o, i))
    }
}

impl std::fmt::Display for Channel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}{}", self.output.letter(), self.input.letter())
    }
}

/// A pose for messages: `(0.100, 0.650, 0.050) m` (millimetre resolution, not the float's
/// every digit).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseText(pub [f64; 3]);

impl std::fmt::Display for PoseText {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let p = self.0;
        write!(f, "({:.3}, {:.3}, {:.3}) m", p[0], p[1], p[2])
    }
}

/// Parses a pose `X,Y,Z` in metres (as the command line and FRF CSV comments give it).
pub fn parse_pose(s: &str) -> Result<[f64; 3], String> {
    let v: Vec<&str> = s.split(',').map(str::trim).collect();
    if v.len() != 3 {
        return Err(format!(
            "expected X,Y,Z in metres (e.g. 0.2,0.1,0.05), got '{s}'"
        ));
    }
    let mut p = [0.0; 3];
    for (i, t) in v.iter().enumerate() {
        p[i] = t
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("'{t}' is not a finite number (expected X,Y,Z in metres)"))?;
    }
    Ok(p)
}

/// `n` and a noun for messages, the noun in the plural unless `n` is 1: `1 mode`,
/// `3 modes`, `1 history entry`, `2 history entries`, `4 teeth`, `0 passes`. The last
/// word of a noun of several words takes the plural.
pub fn count(n: usize, noun: &str) -> String {
    if n == 1 {
        format!("1 {noun}")
    } else {
        format!("{n} {}", plural(noun))
    }
}

/// The English plural of a noun (its last word): `mode` → `modes`, `entry` → `entries`,
/// `pass` → `passes`, `tooth` → `teeth`.
pub fn plural(noun: &str) -> String {
    let (head, last) = match noun.rfind(' ') {
        Some(i) => noun.split_at(i + 1),
        None => ("", noun),
    };
    let many = match last {
        "tooth" => "teeth".to_string(),
        "axis" => "axes".to_string(),
        "datum" => "data".to_string(),
        w if w.ends_with('y')
            && !w.ends_with("ay")
            && !w.ends_with("ey")
            && !w.ends_with("oy")
            && !w.ends_with("uy") =>
        {
            format!("{}ies", &w[..w.len() - 1])
        }
        w if ["s", "x", "ch", "sh"].iter().any(|e| w.ends_with(e)) => format!("{w}es"),
        w => format!("{w}s"),
    };
    format!("{head}{many}")
}

#[cfg(test)]
mod count_tests {
    use super::{count, plural};

    #[test]
    fn one_thing_many_things() {
        assert_eq!(count(1, "mode"), "1 mode");
        assert_eq!(count(3, "mode"), "3 modes");
        assert_eq!(count(0, "pose"), "0 poses");
        assert_eq!(count(1, "history entry"), "1 history entry");
        assert_eq!(count(2, "history entry"), "2 history entries");
        assert_eq!(count(4, "tooth"), "4 teeth");
        assert_eq!(count(2, "pass"), "2 passes");
        assert_eq!(count(2, "operating record"), "2 operating records");
        assert_eq!(plural("key"), "keys");
        assert_eq!(plural("axis"), "axes");
    }
}
